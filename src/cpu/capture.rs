#![forbid(unsafe_code)]
//! The CPU twin of the rasterised CMO capture ([`capture`]): a ray per texel centre from the
//! CMO's centre, traced by the reference's [`Tracer`].

use glam::Vec3;
use rayon::prelude::*;

use crate::reference::{NO_ID, Tracer};
use crate::scene::Scene;

/// The CPU capture of one cubemap object: for every texel, a ray from `centre` through the texel
/// centre ([`crate::cubemap::face::texel_centre_dir`]); the distance to the nearest surface (`+inf`
/// where none), its shaded colour (alpha 1; the background with alpha 0 where none) and the global
/// index of the triangle it hits ([`NO_ID`] where none). Reflectors are left out unless they see
/// themselves ([`crate::scene::Scene::self_capture`]), and then kept only where they face the
/// centre (normal towards it), as in the GPU capture (`spirv/capture.wgsl`). This is what a
/// rasterised capture computes at texel centres, so it checks the GPU capture.
pub fn capture(scene: &Scene, tracer: &Tracer, centre: Vec3, size: u32) -> crate::cubemap::CubeMap {
    capture_shaded(scene, tracer, centre, size, true)
}

/// [`capture`] without colour where `shade` is false (every texel's colour the background's,
/// alpha 1 where a triangle is hit): distances and triangle IDs only, what a trace's status
/// and verification read (the placement search).
pub fn capture_shaded(
    scene: &Scene,
    tracer: &Tracer,
    centre: Vec3,
    size: u32,
    shade: bool,
) -> crate::cubemap::CubeMap {
    let mut cube = crate::cubemap::CubeMap::new(size, centre);
    let n = cube.distance.len();
    let texels: Vec<(f32, [f32; 4], u32)> = (0..n)
        .into_par_iter()
        .map(|i| {
            let t = crate::cubemap::Texel::from_index(i, size);
            let dir = crate::cubemap::face::texel_centre_dir(t, size).normalize();
            let hit = tracer.nearest_accepting(centre, dir, None, |h| {
                let object = &tracer.world.objects
                    [tracer.world.triangle_object[h.triangle as usize] as usize];
                // A reflector's front: against its normals where they point into its closed
                // mesh (`ObjectInfo::normals_inward`), as `scene_front_normal` in the capture.
                let sign = if object.normals_inward { -1.0 } else { 1.0 };
                object.captured
                    && (!object.reflector
                        || (sign * tracer.normal(h)).dot(h.position - centre) <= 0.0)
            });
            match hit {
                Some(h) => {
                    let c = if shade {
                        tracer.shade(scene, &h)
                    } else {
                        scene.background
                    };
                    (
                        (h.position - centre).length(),
                        [c.x, c.y, c.z, 1.0],
                        h.triangle,
                    )
                }
                None => {
                    let b = scene.background;
                    (f32::INFINITY, [b.x, b.y, b.z, 0.0], NO_ID)
                }
            }
        })
        .collect();
    for (i, (d, c, tri)) in texels.into_iter().enumerate() {
        cube.distance[i] = d;
        cube.colour[i] = c;
        cube.triangle[i] = tri;
    }
    cube
}
