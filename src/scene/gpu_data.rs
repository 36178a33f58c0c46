//! The scene flattened into plain `#[repr(C)]` arrays for GPU buffers.
//!
//! The layouts mirror `spirv/shared/scene.wgsl`; a test checks them against naga's layout of
//! the WGSL structs. Textures are one `u32` array of packed sRGB RGBA8 texels (little-endian:
//! red in the low byte) plus a table of (offset, width, height), so that the shader can do the
//! same bilinear filter as [`crate::shading`] with `textureLoad`-style fetches, and decode
//! sRGB through the same 256-entry table the CPU uses. The capture and the reference then shade
//! a point with the same arithmetic.

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

use super::Scene;
use crate::shading::{Shading, srgb_to_linear};

/// One vertex: world position, object id, world normal, texture coordinate.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuVertex {
    pub position: [f32; 3],
    pub object: u32,
    pub normal: [f32; 3],
    /// The vertex colour's red ([`crate::scene::WorldGeometry::colours`]; 1 where the scene
    /// has none), in the slot that aligns `normal`.
    pub colour_r: f32,
    pub uv: [f32; 2],
    /// The vertex colour's green and blue.
    pub colour_gb: [f32; 2],
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuObject {
    pub material: u32,
    /// Bit 0: a reflector; bit 1: its normals point into its closed mesh
    /// ([`crate::scene::ObjectInfo::normals_inward`]; the capture and the reflection-point
    /// search turn them round).
    pub reflector: u32,
    /// 1 where the cubemap capture draws the object: a non-reflector, or a reflector that sees
    /// itself ([`crate::scene::Scene::self_capture`]).
    pub captured: u32,
    /// A glossy reflector's Phong specular power ([`crate::scene::ObjectInfo::specular_power`]);
    /// -1 on a mirror and on every non-reflector.
    pub specular_power: f32,
    /// 1 where its vertex colours multiply its material's colour
    /// ([`crate::scene::ObjectInfo::vertex_colours`]).
    pub vertex_colours: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuMaterial {
    pub diffuse: [f32; 3],
    /// Index into the texture table, or -1.
    pub texture: i32,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuTexture {
    /// First texel in the texel array.
    pub offset: u32,
    pub width: u32,
    pub height: u32,
    pub _pad: u32,
}

/// The shading model as a uniform block.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuShading {
    /// 0: unlit, 1: Lambert.
    pub model: u32,
    pub ambient: f32,
    pub light_intensity: f32,
    pub _pad: u32,
    /// Towards the light.
    pub light_direction: [f32; 3],
    pub _pad2: u32,
    pub background: [f32; 3],
    pub _pad3: u32,
}

/// Everything the capture and G-buffer passes read about the scene.
#[derive(Clone, Debug, Default)]
pub struct GpuSceneData {
    pub vertices: Vec<GpuVertex>,
    /// Triangle list in [`crate::scene::WorldGeometry::triangles`] order: global triangle `k`
    /// is `indices[3k..3k + 3]`.
    pub indices: Vec<u32>,
    /// Indices of the captured triangles ([`GpuObject::captured`]): what the capture may
    /// rasterise (each face draws those of them that can reach it, by their global indices).
    pub capture_index_count: u32,
    pub objects: Vec<GpuObject>,
    pub materials: Vec<GpuMaterial>,
    pub textures: Vec<GpuTexture>,
    pub texels: Vec<u32>,
    pub srgb_to_linear: Vec<f32>,
    pub shading: GpuShading,
}

impl GpuSceneData {
    pub fn new(scene: &Scene) -> Self {
        let world = scene.world();
        // Each object has its own vertices in `WorldGeometry`, so a vertex has one object.
        let mut vertex_object = vec![0u32; world.positions.len()];
        for (t, &o) in world.triangles.iter().zip(&world.triangle_object) {
            for &i in t {
                vertex_object[i as usize] = o;
            }
        }
        let colour = |i: usize| world.colours.get(i).copied().unwrap_or(Vec3::ONE);
        let vertices = (0..world.positions.len())
            .map(|i| {
                let [r, g, b] = colour(i).to_array();
                GpuVertex {
                    position: world.positions[i].to_array(),
                    object: vertex_object[i],
                    normal: world.normals[i].to_array(),
                    uv: world.uvs[i].to_array(),
                    colour_r: r,
                    colour_gb: [g, b],
                }
            })
            .collect();
        let captured = |t: usize| world.objects[world.triangle_object[t] as usize].captured;
        // Indices in `WorldGeometry::triangles` order: triangle `k` is indices `3k..3k + 3`, so a
        // draw's `vertex_index / 3` is the global triangle index.
        let indices: Vec<u32> = world.triangles.iter().flatten().copied().collect();
        let capture_index_count =
            3 * (0..world.triangles.len()).filter(|&t| captured(t)).count() as u32;
        let mut textures = Vec::new();
        let mut texels = Vec::new();
        for t in &scene.textures {
            textures.push(GpuTexture {
                offset: texels.len() as u32,
                width: t.width,
                height: t.height,
                _pad: 0,
            });
            texels.extend(
                t.rgba8
                    .chunks_exact(4)
                    .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])),
            );
        }
        if texels.is_empty() {
            // Storage buffers cannot be empty.
            texels.push(0);
            textures.push(GpuTexture::default());
        }
        let shading = match scene.shading {
            Shading::Unlit => GpuShading {
                model: 0,
                ..GpuShading::default()
            },
            Shading::Lambert {
                ambient,
                light_direction,
                light_intensity,
            } => GpuShading {
                model: 1,
                ambient,
                light_intensity,
                light_direction: light_direction.to_array(),
                ..GpuShading::default()
            },
        };
        GpuSceneData {
            vertices,
            indices,
            capture_index_count,
            objects: world
                .objects
                .iter()
                .map(|o| GpuObject {
                    material: o.material,
                    reflector: o.reflector as u32 | (o.normals_inward as u32) << 1,
                    captured: o.captured as u32,
                    specular_power: o.specular_power.unwrap_or(-1.0),
                    vertex_colours: o.vertex_colours as u32,
                })
                .collect(),
            materials: scene
                .materials
                .iter()
                .map(|m| GpuMaterial {
                    diffuse: m.diffuse.to_array(),
                    texture: m.texture.map_or(-1, |t| t as i32),
                })
                .collect(),
            textures,
            texels,
            srgb_to_linear: (0..=255u8).map(srgb_to_linear).collect(),
            shading: GpuShading {
                background: scene.background.to_array(),
                ..shading
            },
        }
    }

    /// Triangles the cubemap capture draws: reflectors only where they see themselves.
    pub fn capture_triangles(&self) -> u32 {
        self.capture_index_count / 3
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn indices_in_world_order_and_reflectors_counted() {
        let s = crate::scene::builtin::sphere_room();
        let g = GpuSceneData::new(&s);
        let world = s.world();
        for (k, t) in world.triangles.iter().enumerate() {
            assert_eq!(&g.indices[3 * k..3 * k + 3], t);
        }
        let reflector = |i: u32| g.objects[g.vertices[i as usize].object as usize].reflector;
        let others = g.indices.iter().filter(|&&i| reflector(i) == 0).count();
        // The sphere is convex: it does not see itself, so the capture leaves it out.
        assert_eq!(g.capture_index_count as usize, others);
        assert!(g.capture_triangles() > 0);
        assert!(g.capture_triangles() < g.indices.len() as u32 / 3);
        let mut on = s.clone();
        on.self_reflections = crate::scene::SelfReflections::On;
        assert_eq!(
            GpuSceneData::new(&on).capture_triangles(),
            g.indices.len() as u32 / 3
        );
        assert_eq!(g.srgb_to_linear[255], 1.0);
        // Texels: red in the low byte.
        let t = &s.textures[0];
        assert_eq!(g.texels[0] & 0xff, t.rgba8[0] as u32);
    }
}
