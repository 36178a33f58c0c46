#![forbid(unsafe_code)]
//! The shape of a method's shader that the model counts: its code blocks ([`Block`]) and its
//! static loop nest ([`Stmt`]). Each method's own blocks are in its file under
//! [`super::methods`].

/// A code block of a method's shader that the model counts: a loop body or a call site.
///
/// The weight of a block (`model::weights`) is the SPIR-V instruction count of its
/// `functions`, callees included, EXCEPT a callee that another block of the same method names
/// (that one is counted by its own block, once per its own count). A name listed twice counts
/// twice (the block calls it twice per count).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Block {
    /// Short stable name, used in JSON ("lane_test", "advance", ...).
    pub name: &'static str,
    /// The WGSL file (under spirv/) and the WGSL functions whose instructions the block runs
    /// once per count (callees included by the weights).
    pub shader: &'static str,
    pub functions: &'static [&'static str],
}

pub(super) const fn b(
    name: &'static str,
    shader: &'static str,
    functions: &'static [&'static str],
) -> Block {
    Block {
        name,
        shader,
        functions,
    }
}

/// One statement of a shader's static loop nest: a block, or a loop (by id) with its body.
/// Every block sits in one place; a loop runs at most once per turn of its parent.
#[derive(Clone, Copy, Debug)]
pub enum Stmt {
    Block(usize),
    Loop(u16, &'static [Stmt]),
}
