//! Response to a change of light (lag): turn a light off, turn one on, move one, and count the
//! frames the GI image takes to reach its new steady state.
//!
//! The light that changes is the scene's brightest emissive material (by emitted power over its
//! triangles), else its brightest punctual light (point and spot lights before directional
//! ones): off sets its emission or intensity to zero, on starts from that and restores it, move
//! translates every instance that carries the material, or the light, by a quarter of the
//! scene's extent along its longest horizontal axis, toward the centre. The world cache keeps its
//! light across the change ([`GiRenderer::change_scene`] without resetting it), as an engine's
//! would; the screen-space history starts over there, so the figures are the cache's lag and the
//! denoiser's history growing back, not a kept screen-space history following the change.
//!
//! The measure is the share of the change still missing: with `S_old` and `S_new` the two scenes'
//! steady states (the mean of the last frames of a long still run of each) and `I_t` the `t`-th
//! frame after the change, `Σ |I_t − S_new| / Σ |S_old − S_new|` over the luminance of 8 × 8-pixel
//! blocks (blocks, so that one frame's noise does not read as lag). A light switched off that
//! leaves 5 % of its light reads 0.05.
//!
//! Failure modes: the steady states carry the renderer's residual noise, so the share levels
//! off a little above 0 (about 0.01 on the test scenes); a change that moves little light (a
//! small lamp in a big lit room) has a small denominator and a noisier share.

use crate::error::{Error, Result};
use crate::gi::renderer::GiRenderer;
use crate::gi::{GiSettings, ViewOptions};
use crate::image_io::HdrImage;
use crate::scene::lights::LightSet;
use crate::scene::upload::GpuScene;
use crate::scene::{LightKind, Scene};
use crate::vulkan::Context;
use gi_shared::camera::CameraParams;
use gi_shared::color::luminance;
use glam::{Mat4, Vec3};

/// Side of the blocks whose luminance the measure compares, pixels.
pub const BLOCK: u32 = 8;
/// The share of the change that counts as "reached the new steady state".
pub const SETTLED: f64 = 0.05;

/// A change of light.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LightChange {
    /// The brightest emitter switched off.
    Off,
    /// The brightest emitter switched on (from off).
    On,
    /// The brightest emitter moved.
    Move,
}

impl LightChange {
    /// All three, in the order the tables list them.
    pub const ALL: [Self; 3] = [Self::Off, Self::On, Self::Move];

    /// Its name in tables.
    pub fn name(self) -> &'static str {
        match self {
            Self::Off => "off",
            Self::On => "on",
            Self::Move => "move",
        }
    }

    /// The scene before the change and after it, made from `scene`; an error naming the scene
    /// when it has nothing to switch, or for a move, nothing that can move.
    pub fn scenes(self, scene: &Scene) -> Result<(Scene, Scene)> {
        let name = scene.source.display();
        let size = scene.bounds.size();
        let axis = if size.x >= size.z { Vec3::X } else { Vec3::Z };
        // A quarter of the extent along `axis`, toward the centre from `at`.
        let step = |at: Vec3| {
            let toward = if (scene.bounds.center() - at).dot(axis) >= 0.0 {
                1.0
            } else {
                -1.0
            };
            axis * (toward * 0.25 * size.dot(axis))
        };
        let (off, moved) = if let Some(material) = brightest_emitter(scene) {
            let mut materials = scene.materials.clone();
            materials[material].emissive = Vec3::ZERO;
            let off = rebuilt(scene, scene.instances.clone(), materials);
            let shift = Mat4::from_translation(step(emitter_centre(scene, material)));
            let mut instances = scene.instances.clone();
            for instance in &mut instances {
                let mesh = &scene.meshes[instance.mesh as usize];
                if mesh.materials.iter().any(|&m| m as usize == material) {
                    instance.transform = shift * instance.transform;
                }
            }
            (
                off,
                Some(rebuilt(scene, instances, scene.materials.clone())),
            )
        } else if let Some(light) = brightest_punctual(scene) {
            let mut lights = scene.lights.clone();
            lights[light].intensity = Vec3::ZERO;
            let off = Scene {
                lights,
                ..scene.clone()
            };
            let moved = (scene.lights[light].kind != LightKind::Directional).then(|| {
                let mut lights = scene.lights.clone();
                let at = lights[light].position;
                lights[light].position += step(at);
                Scene {
                    lights,
                    ..scene.clone()
                }
            });
            (off, moved)
        } else {
            return Err(Error::InvalidArgument {
                name: "scene",
                why: format!("{name}: no emissive material or punctual light to switch"),
            });
        };
        Ok(match self {
            Self::Off => (scene.clone(), off),
            Self::On => (off, scene.clone()),
            Self::Move => (
                scene.clone(),
                moved.ok_or_else(|| Error::InvalidArgument {
                    name: "scene",
                    why: format!("{name}: its brightest light is directional: nothing to move"),
                })?,
            ),
        })
    }
}

/// The brightest point or spot light (by the luminance of its intensity), else the brightest
/// directional one.
fn brightest_punctual(scene: &Scene) -> Option<usize> {
    let rank = |i: &usize| {
        let l = &scene.lights[*i];
        (l.kind != LightKind::Directional, luminance(l.intensity))
    };
    (0..scene.lights.len())
        .filter(|&i| luminance(scene.lights[i].intensity) > 0.0)
        .max_by(|a, b| {
            let (ka, la) = rank(a);
            let (kb, lb) = rank(b);
            ka.cmp(&kb).then(la.total_cmp(&lb))
        })
}

/// The emissive material with the most emitted power (luminance × area over its triangles).
fn brightest_emitter(scene: &Scene) -> Option<usize> {
    let mut power = vec![0.0f64; scene.materials.len()];
    for t in scene.world_triangles() {
        let Some(m) = scene.materials.get(t.material as usize) else {
            continue;
        };
        let [a, b, c] = t.vertices;
        let area = 0.5 * f64::from((b - a).cross(c - a).length());
        power[t.material as usize] += area * f64::from(luminance(m.emissive));
    }
    (0..power.len())
        .filter(|&m| power[m] > 0.0)
        .max_by(|&a, &b| power[a].total_cmp(&power[b]))
}

/// The mean of the centroids of `material`'s world triangles.
fn emitter_centre(scene: &Scene, material: usize) -> Vec3 {
    let (mut sum, mut count) = (Vec3::ZERO, 0.0f32);
    for t in scene.world_triangles() {
        if t.material as usize == material {
            sum += (t.vertices[0] + t.vertices[1] + t.vertices[2]) / 3.0;
            count += 1.0;
        }
    }
    sum / count.max(1.0)
}

/// `scene` with other instances or materials, its derived data rebuilt; cameras kept.
fn rebuilt(
    scene: &Scene,
    instances: Vec<crate::scene::Instance>,
    materials: Vec<crate::scene::Material>,
) -> Scene {
    let mut out = Scene::from_parts(
        scene.source.clone(),
        scene.meshes.clone(),
        instances,
        materials,
        scene.textures.clone(),
        scene.lights.clone(),
    );
    out.cameras = scene.cameras.clone();
    out
}

/// How one run answered a change.
#[derive(Clone, Debug, PartialEq)]
pub struct Response {
    /// The change.
    pub change: LightChange,
    /// The share of the change still missing in each frame after it (frame 1 first).
    pub remaining: Vec<f64>,
}

impl Response {
    /// The first frame after the change from which on the share stays at most [`SETTLED`];
    /// `None` when the run ended before.
    pub fn frames_to_settle(&self) -> Option<u32> {
        let last_unsettled = self.remaining.iter().rposition(|&r| r > SETTLED);
        match last_unsettled {
            None => Some(1),
            Some(i) if i + 1 < self.remaining.len() => Some(i as u32 + 2),
            Some(_) => None,
        }
    }

    /// The share still missing `frames` frames after the change.
    pub fn after(&self, frames: u32) -> Option<f64> {
        self.remaining.get(frames.checked_sub(1)? as usize).copied()
    }
}

/// Frames of a measurement.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Frames {
    /// Still frames before the change (and of the run that finds the new steady state).
    pub warm_up: u32,
    /// The last frames of those whose mean is the steady state.
    pub steady: u32,
    /// Frames measured after the change.
    pub after: u32,
}

/// Measures `change` on `scene` seen by `camera`, rendered with `settings`: the share still
/// missing in each frame, averaged over the random streams `0..seeds` (one stream is one noisy
/// realisation of the response: at 64 × 64 two tracing variants' single runs gave 0.032 and 0.10
/// for the same light switched on).
pub fn measure(
    ctx: &Context,
    scene: &Scene,
    change: LightChange,
    camera: &CameraParams,
    settings: GiSettings,
    frames: Frames,
    seeds: u32,
) -> Result<Response> {
    if frames.steady == 0 || frames.steady > frames.warm_up || frames.after == 0 {
        return Err(Error::InvalidArgument {
            name: "frames",
            why: format!("{frames:?}: need 0 < steady <= warm_up and after > 0"),
        });
    }
    if seeds == 0 {
        return Err(Error::InvalidArgument {
            name: "seeds",
            why: "0: need at least one random stream".into(),
        });
    }
    let (before, after) = change.scenes(scene)?;
    let upload = |s: &Scene| GpuScene::upload_lit(ctx, s, None, true);
    let (before_lights, before_gpu) = upload(&before)?;
    let (after_lights, after_gpu) = upload(&after)?;
    let renderer = |lights: &LightSet, seed: u32| {
        GiRenderer::new(
            ctx,
            lights,
            camera.image_size[0],
            camera.image_size[1],
            settings,
            ViewOptions {
                seed,
                ..ViewOptions::default()
            },
        )
    };
    let steady = |gi: &mut GiRenderer, gpu: &GpuScene| -> Result<Vec<f64>> {
        let mut sum: Vec<f64> = Vec::new();
        for f in 0..frames.warm_up {
            gi.render_frame(ctx, gpu, camera)?;
            if f >= frames.warm_up - frames.steady {
                let b = blocks(&gi.image(ctx)?);
                sum.resize(b.len(), 0.0);
                sum.iter_mut().zip(b).for_each(|(s, v)| *s += v);
            }
        }
        Ok(sum
            .into_iter()
            .map(|s| s / f64::from(frames.steady))
            .collect())
    };
    let mut remaining = vec![0.0; frames.after as usize];
    for seed in 0..seeds {
        let new_state = steady(&mut renderer(&after_lights, seed)?, &after_gpu)?;
        let mut gi = renderer(&before_lights, seed)?;
        let old_state = steady(&mut gi, &before_gpu)?;
        let total: f64 = old_state
            .iter()
            .zip(&new_state)
            .map(|(a, b)| (a - b).abs())
            .sum();
        if total <= 0.0 {
            return Err(Error::InvalidArgument {
                name: "scene",
                why: format!(
                    "{}: the {} change moves no light in this view",
                    scene.source.display(),
                    change.name()
                ),
            });
        }
        gi.change_scene(ctx, &after_lights, false)?;
        for r in &mut remaining {
            gi.render_frame(ctx, &after_gpu, camera)?;
            let b = blocks(&gi.image(ctx)?);
            let missing: f64 = b.iter().zip(&new_state).map(|(a, b)| (a - b).abs()).sum();
            *r += missing / total / f64::from(seeds);
        }
    }
    Ok(Response { change, remaining })
}

/// Mean luminance of each [`BLOCK`]²-pixel block (partial blocks at the right and bottom edges
/// included), non-finite pixels as 0.
fn blocks(image: &HdrImage) -> Vec<f64> {
    let (w, h) = (image.width(), image.height());
    let (bw, bh) = (w.div_ceil(BLOCK), h.div_ceil(BLOCK));
    let mut sums = vec![0.0f64; (bw * bh) as usize];
    let mut counts = vec![0u32; sums.len()];
    for (i, c) in image.pixels().iter().enumerate() {
        let (x, y) = (i as u32 % w, i as u32 / w);
        let b = ((y / BLOCK) * bw + x / BLOCK) as usize;
        let l = f64::from(luminance(Vec3::from_array(*c)));
        sums[b] += if l.is_finite() { l } else { 0.0 };
        counts[b] += 1;
    }
    sums.iter()
        .zip(counts)
        .map(|(s, n)| s / f64::from(n.max(1)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::procedural::{cube, scaling_room, scene};

    fn cornell_box() -> Scene {
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/cornell-box.gltf");
        Scene::load(path).unwrap().0
    }

    #[test]
    fn the_brightest_emitter_is_switched_and_moved() {
        let scene = cornell_box();
        assert!(!scene.emissive_triangles.is_empty());
        let (before, off) = LightChange::Off.scenes(&scene).unwrap();
        assert_eq!(before.emissive_triangles, scene.emissive_triangles);
        assert!(off.emissive_triangles.is_empty(), "its only emitter is off");
        let (dark, lit) = LightChange::On.scenes(&scene).unwrap();
        assert!(dark.emissive_triangles.is_empty());
        assert_eq!(lit.emissive_triangles, scene.emissive_triangles);
        // Moved a quarter of the box's 2 m along x (its longest horizontal axis, or z on a
        // tie), toward the centre, and nothing else.
        let (_, moved) = LightChange::Move.scenes(&scene).unwrap();
        let centre = |s: &Scene| {
            s.emissive_triangles
                .iter()
                .map(|t| t.vertices[0])
                .sum::<Vec3>()
                / s.emissive_triangles.len() as f32
        };
        let shift = centre(&moved) - centre(&scene);
        assert!((shift.length() - 0.5).abs() < 1e-3, "{shift}");
        assert!(shift.y.abs() < 1e-6);
        assert_eq!(moved.cameras, scene.cameras);
    }

    #[test]
    fn without_emitters_the_brightest_punctual_light_changes() {
        let room = scaling_room(0, 3).unwrap();
        let (_, off) = LightChange::Off.scenes(&room).unwrap();
        let dark = off
            .lights
            .iter()
            .filter(|l| l.intensity == Vec3::ZERO)
            .count();
        assert_eq!(dark, 1);
        let (_, moved) = LightChange::Move.scenes(&room).unwrap();
        let changed: Vec<_> = room
            .lights
            .iter()
            .zip(&moved.lights)
            .filter(|(a, b)| a.position != b.position)
            .collect();
        assert_eq!(changed.len(), 1);
        let (a, b) = changed[0];
        let inside =
            b.position.cmpge(room.bounds.min).all() && b.position.cmple(room.bounds.max).all();
        assert!(inside, "{} moved out to {}", a.position, b.position);
    }

    #[test]
    fn a_scene_without_light_is_an_error_that_names_it() {
        let mut unlit = scene(vec![cube()], &[(0, Mat4::IDENTITY)]).unwrap();
        unlit.source = "unlit.gltf".into();
        for change in LightChange::ALL {
            let e = change.scenes(&unlit).unwrap_err().to_string();
            assert!(e.contains("unlit.gltf"), "{e}");
        }
    }

    #[test]
    fn settling_is_the_first_frame_from_which_the_share_stays_small() {
        let response = |remaining: &[f64]| Response {
            change: LightChange::Off,
            remaining: remaining.to_vec(),
        };
        assert_eq!(response(&[0.01, 0.02]).frames_to_settle(), Some(1));
        assert_eq!(
            response(&[0.5, 0.04, 0.06, 0.01]).frames_to_settle(),
            Some(4)
        );
        assert_eq!(response(&[0.5, 0.04, 0.06]).frames_to_settle(), None);
        assert_eq!(response(&[0.5, 0.04]).after(2), Some(0.04));
        assert_eq!(response(&[0.5]).after(0), None);
        assert_eq!(response(&[0.5]).after(2), None);
    }
}
