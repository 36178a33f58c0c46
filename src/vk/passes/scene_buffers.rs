//! The scene's GPU buffers: `@group(0)` of every pass that imports `spirv/shared/scene.wgsl`.
//!
//! Invariants: the contents are [`GpuSceneData`] as is (layouts checked against naga's in
//! tests/capture/gpu_raster.rs); `indices` is in global triangle order (`WorldGeometry::triangles`),
//! so a draw's `vertex_index / 3` is the global triangle index. Where only the geometry's
//! placement changes (a mesh moved), [`SceneBuffers::write_geometry`] rewrites the vertices in
//! place and every bind group over these buffers stays valid.
use ash::vk;

use crate::scene::gpu_data::GpuSceneData;
use crate::vk::backend::buffer::Buffer;
use crate::vk::backend::context::GpuContext;
use crate::vk::backend::error::{VkError, VkResult};
use crate::vk::backend::pipeline::Resource;
use crate::vk::backend::shaders::Pass;

/// `data`, or one zeroed element where it is empty (a scene without meshes or materials): a
/// storage buffer must hold at least one element of its binding's type. No pass reads it, since
/// [`SceneBuffers::index_count`] stays that of `data`.
fn at_least_one<T: bytemuck::Pod>(data: &[T]) -> std::borrow::Cow<'_, [T]> {
    if data.is_empty() {
        vec![T::zeroed()].into()
    } else {
        data.into()
    }
}

/// Uploaded scene data.
pub struct SceneBuffers {
    vertices: Buffer,
    indices: Buffer,
    objects: Buffer,
    materials: Buffer,
    textures: Buffer,
    texels: Buffer,
    srgb: Buffer,
    shading: Buffer,
    /// Indices of every triangle.
    pub index_count: u32,
}

impl SceneBuffers {
    /// Uploads `data`.
    pub fn new(ctx: &GpuContext, data: &GpuSceneData) -> VkResult<Self> {
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        Ok(SceneBuffers {
            vertices: ctx.create_buffer_init(
                "scene vertices",
                storage,
                &at_least_one(&data.vertices),
            )?,
            indices: ctx.create_buffer_init(
                "scene indices",
                storage,
                &at_least_one(&data.indices),
            )?,
            objects: ctx.create_buffer_init(
                "scene objects",
                storage,
                &at_least_one(&data.objects),
            )?,
            materials: ctx.create_buffer_init(
                "scene materials",
                storage,
                &at_least_one(&data.materials),
            )?,
            textures: ctx.create_buffer_init("scene textures", storage, &data.textures)?,
            texels: ctx.create_buffer_init("scene texels", storage, &data.texels)?,
            srgb: ctx.create_buffer_init("sRGB table", storage, &data.srgb_to_linear)?,
            shading: ctx.create_buffer_init(
                "scene shading",
                vk::BufferUsageFlags::STORAGE_BUFFER,
                std::slice::from_ref(&data.shading),
            )?,
            index_count: data.indices.len() as u32,
        })
    }

    /// Why `new` cannot replace `old` in these buffers in place ([`SceneBuffers::write_geometry`]),
    /// `None` where it can: the same vertex count and everything but the vertices equal (the
    /// triangles, objects, materials, textures and shading), so that only the vertex buffer's
    /// contents change and every pass bound to these buffers stays valid.
    pub fn in_place_blocker(old: &GpuSceneData, new: &GpuSceneData) -> Option<String> {
        // Every field named: a new one must be compared (or rewritten) before this compiles.
        let GpuSceneData {
            vertices: _,
            indices: _,
            capture_index_count: _,
            objects: _,
            materials: _,
            textures: _,
            texels: _,
            srgb_to_linear: _,
            shading: _,
        } = new;
        let differs = |what: &str| Some(format!("the scene's {what} changed"));
        if old.vertices.len() != new.vertices.len() {
            return Some(format!(
                "the vertex count changed ({} -> {})",
                old.vertices.len(),
                new.vertices.len()
            ));
        }
        if old.indices != new.indices || old.capture_index_count != new.capture_index_count {
            return differs("triangles");
        }
        if old.objects != new.objects {
            return differs("objects (reflector, captured or inward-normal flags)");
        }
        if old.materials != new.materials {
            return differs("materials");
        }
        if old.textures != new.textures || old.texels != new.texels {
            return differs("textures");
        }
        if old.shading != new.shading || old.srgb_to_linear != new.srgb_to_linear {
            return differs("shading");
        }
        None
    }

    /// Rewrites the vertex buffer (world positions, normals) with `data`'s, of the vertex count
    /// of creation ([`SceneBuffers::in_place_blocker`] says when the rest is unchanged): the
    /// buffers then hold what [`SceneBuffers::new`] of `data` would upload.
    pub fn write_geometry(&self, ctx: &GpuContext, data: &GpuSceneData) -> VkResult<()> {
        let vertices = at_least_one(&data.vertices);
        if size_of_val(vertices.as_ref()) as u64 != self.vertices.size() {
            return Err(VkError::Usage {
                what: "scene vertices".into(),
                detail: format!(
                    "{} vertices for a buffer of {} bytes: the vertex count is fixed at creation",
                    data.vertices.len(),
                    self.vertices.size()
                ),
            });
        }
        ctx.write_buffer(&self.vertices, &vertices)
    }

    /// The resources of [`SceneBuffers::resources`] that `entries` of `pass` use (a bind group
    /// must not supply more than its layout declares).
    pub fn resources_for(&self, pass: &Pass, entries: &[&str]) -> Vec<(u32, Resource<'_>)> {
        let used = |binding: u32| {
            entries.iter().any(|name| {
                pass.entry_point(name).is_some_and(|e| {
                    e.bindings
                        .iter()
                        .any(|b| b.group == 0 && b.binding == binding)
                })
            })
        };
        self.resources()
            .into_iter()
            .filter(|(b, _)| used(*b))
            .collect()
    }

    /// The `(binding, resource)` list of `@group(0)`.
    pub fn resources(&self) -> [(u32, Resource<'_>); 8] {
        [
            (0, Resource::Buffer(&self.vertices)),
            (1, Resource::Buffer(&self.indices)),
            (2, Resource::Buffer(&self.objects)),
            (3, Resource::Buffer(&self.materials)),
            (4, Resource::Buffer(&self.textures)),
            (5, Resource::Buffer(&self.texels)),
            (6, Resource::Buffer(&self.srgb)),
            (7, Resource::Buffer(&self.shading)),
        ]
    }
}
