//! Everything that emits, in the layout of `gi_shared::lights` and `gi_shared::environment`:
//! punctual lights, then emissive triangles, then the environment image when it is sampled, in
//! one buffer with a power-proportional alias table; the triangle→light table that MIS needs;
//! the environment's texels and its sampling distribution.
//!
//! Only what the scene has is uploaded: a scene without lights binds one-element placeholders (a
//! Vulkan buffer cannot be empty) and passes a light count of 0. Beside them, the clusters the
//! light grid weighs (`gi_shared::light_clusters`), which only the grid's build binds.
//!
//! # Power
//!
//! Selection is proportional to each light's emitted power (luminance of the RGB): a point light
//! `4π I`, a spot light `2π (1 − (cos_inner + cos_outer)/2) I` (its cone), a triangle `π L A`
//! per emitting side, and lights from outside the scene by what crosses its bounding sphere of
//! radius `R`: a directional light `π R² E`, the environment `π R² ∫ L dω`. A light of zero power
//! is never selected (it adds nothing); when every light has zero power selection is uniform.

use super::{LightKind, Scene};
use crate::error::{Error, Result};
use crate::image_io::HdrImage;
use crate::vulkan::{Buffer, Context, Resource, StagedWrites};
use ash::vk;
use gi_shared::color::luminance;
use gi_shared::environment::distribution_len;
use gi_shared::layout::MAX_STORAGE_BUFFER_BYTES;
use gi_shared::light_clusters::{LIGHT_GRID_MAX_CLUSTERS, LightCluster, build_light_clusters};
use gi_shared::lights::{EMIT_BACK, EMIT_FRONT, GpuLight, LightSources, SceneLights};
use gi_shared::scene_data::NONE;
use glam::Vec3;
use std::f64::consts::PI;

/// Size of [`Environment::constant`]'s image.
pub const CONSTANT_SKY_SIZE: [u32; 2] = [32, 16];

/// An equirectangular environment image (see `gi_shared::environment` for its orientation) and
/// its sampling distribution.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Environment {
    size: [u32; 2],
    texels: Vec<[f32; 4]>,
    distribution: Vec<f32>,
    /// `∫ luminance(L) dω` over the sphere.
    luminance_integral: f64,
}

impl Environment {
    /// The environment of `texels` (RGB and an unused fourth channel, row by row from the top)
    /// of a `size` image. Errors when the count does not match the size, when the image is
    /// empty, or when it does not fit one storage binding (`MAX_STORAGE_BUFFER_BYTES`: up to
    /// 4096 × 2048 texels), and when an RGB channel is NaN or infinite (every ray that escapes
    /// would carry it). Negative texels (filtered captures have some) are kept but weigh nothing
    /// in the distribution.
    pub fn new(size: [u32; 2], texels: Vec<[f32; 4]>) -> Result<Self> {
        let [w, h] = size;
        if w == 0 || h == 0 || w as usize * h as usize != texels.len() {
            return Err(Error::InvalidArgument {
                name: "environment",
                why: format!("{} texels for a {w}x{h} image", texels.len()),
            });
        }
        if let Some(i) = texels
            .iter()
            .position(|t| !t[..3].iter().all(|c| c.is_finite()))
        {
            let bad = texels
                .iter()
                .filter(|t| !t[..3].iter().all(|c| c.is_finite()));
            let kind = match texels[i][..3].iter().any(|c| c.is_nan()) {
                true => "NaN",
                false => "infinite",
            };
            return Err(Error::InvalidArgument {
                name: "environment",
                why: format!(
                    "texel ({}, {}) is {kind} ({} texels are NaN or infinite): an environment \
                     must be finite",
                    i % w as usize,
                    i / w as usize,
                    bad.count()
                ),
            });
        }
        let bytes = std::mem::size_of_val(texels.as_slice());
        if bytes > MAX_STORAGE_BUFFER_BYTES {
            return Err(Error::InvalidArgument {
                name: "environment",
                why: format!(
                    "{w}x{h} texels take {bytes} bytes, more than the {} MiB a storage buffer \
                     binding may hold on every device: use a smaller image",
                    MAX_STORAGE_BUFFER_BYTES >> 20
                ),
            });
        }
        // Weights: luminance × the texel's solid angle, (2π/w)(π/h) sin θ at the row's centre.
        let (wu, hu) = (w as usize, h as usize);
        let mut distribution = vec![0.0f32; distribution_len(w, h)];
        let mut rows = vec![0.0f64; hu];
        let texel_area = 2.0 * PI * PI / (w as f64 * h as f64);
        for y in 0..hu {
            let sin_theta = ((y as f64 + 0.5) / h as f64 * PI).sin();
            let first = (hu + 1) + y * (wu + 1);
            let mut sum = 0.0f64;
            let mut cumulative = vec![0.0f64; wu + 1];
            for x in 0..wu {
                let t = texels[y * wu + x];
                let l = f64::from(luminance(Vec3::new(t[0], t[1], t[2])));
                sum += if l.is_finite() && l > 0.0 { l } else { 0.0 };
                cumulative[x + 1] = sum;
            }
            for (x, c) in cumulative.iter().enumerate() {
                distribution[first + x] = if sum > 0.0 {
                    (c / sum) as f32
                } else {
                    x as f32 / w as f32
                };
            }
            distribution[first + wu] = 1.0;
            rows[y] = sum * sin_theta * texel_area;
        }
        let total: f64 = rows.iter().sum();
        let mut acc = 0.0;
        for (y, r) in rows.iter().enumerate() {
            acc += r;
            distribution[y + 1] = if total > 0.0 {
                (acc / total) as f32
            } else {
                (y + 1) as f32 / h as f32
            };
        }
        distribution[hu] = 1.0;
        Ok(Self {
            size,
            texels,
            distribution,
            luminance_integral: total,
        })
    }

    /// A uniform sky of radiance `sky` as a small environment image, so that light sampling
    /// (next-event estimation, the light grid) can draw it like an image: 32 × 16 texels, enough
    /// for the rows' `sin θ` weights to follow the sphere's solid angle.
    pub fn constant(sky: Vec3) -> Result<Self> {
        let [w, h] = CONSTANT_SKY_SIZE;
        Self::new(
            CONSTANT_SKY_SIZE,
            vec![[sky.x, sky.y, sky.z, 0.0]; (w * h) as usize],
        )
    }

    /// The equirectangular environment image at `path` (OpenEXR or Radiance HDR); an error
    /// names the file.
    pub fn read(path: &std::path::Path) -> Result<Self> {
        let image = HdrImage::read(path)?;
        Self::from_image(&image).map_err(|e| match e {
            Error::InvalidArgument { why, .. } => Error::Image {
                path: path.to_owned(),
                why,
            },
            other => other,
        })
    }

    /// The environment of an equirectangular image.
    pub fn from_image(image: &HdrImage) -> Result<Self> {
        Self::new(
            [image.width(), image.height()],
            image
                .pixels()
                .iter()
                .map(|p| [p[0], p[1], p[2], 0.0])
                .collect(),
        )
    }

    /// Width and height in texels.
    pub fn size(&self) -> [u32; 2] {
        self.size
    }

    /// Texels row by row from the top, RGB and an unused fourth channel.
    pub fn texels(&self) -> &[[f32; 4]] {
        &self.texels
    }

    /// The sampling distribution (`gi_shared::environment`'s layout).
    pub fn distribution(&self) -> &[f32] {
        &self.distribution
    }
}

/// What the kernel's parameters say about the lights.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LightParams {
    /// Lights in the buffer.
    pub count: u32,
    /// Size of the environment image, zero for none.
    pub environment_size: [u32; 2],
    /// Index of the environment's light, [`NONE`] when it is not sampled.
    pub environment_light: u32,
}

/// Every emitter of a scene, on the CPU: the path tracer on the CPU reads it as it is, and
/// [`GpuLights`] uploads it.
#[derive(Clone, Debug, Default)]
pub struct LightSet {
    /// Punctual lights in file order, the emissive triangles, then the environment when sampled;
    /// with their selection probabilities and alias table.
    pub lights: Vec<GpuLight>,
    /// The triangle→light table (`gi_shared::lights::light_of_triangle`).
    pub triangle_table: Vec<u32>,
    /// The environment image, if any (sampled or not).
    pub environment: Option<Environment>,
    /// Index of the environment's light, [`NONE`] when it is not sampled.
    pub environment_light: u32,
    /// The clusters the light grid weighs (`gi_shared::light_clusters`): one per light up to
    /// `LIGHT_GRID_MAX_CLUSTERS` lights; empty without lights.
    pub clusters: Vec<LightCluster>,
}

impl LightSet {
    /// The lights as the shared shading code takes them.
    pub fn scene_lights(&self) -> SceneLights<'_> {
        let (environment, environment_cdf) = self
            .environment
            .as_ref()
            .map_or((&[][..], &[][..]), |e| (e.texels(), e.distribution()));
        SceneLights {
            sources: LightSources {
                lights: &self.lights,
                environment,
                environment_cdf,
            },
            light_table: &self.triangle_table,
        }
    }

    /// The emitters of `scene`, and `environment` as the sky; the environment is importance-
    /// sampled (a light of its own) when `sample_environment` is set.
    pub fn new(scene: &Scene, environment: Option<Environment>, sample_environment: bool) -> Self {
        let extent = if scene.bounds.is_empty() {
            Vec3::ONE
        } else {
            scene.bounds.size()
        };
        let radius = 0.5 * f64::from(extent.length());
        let outside = PI * radius * radius;
        let lum = |c: Vec3| f64::from(luminance(c));
        let mut lights = Vec::new();
        let mut power = Vec::new();
        for l in &scene.lights {
            let (light, p) = match l.kind {
                LightKind::Point => (
                    GpuLight::point(l.position, l.intensity),
                    4.0 * PI * lum(l.intensity),
                ),
                LightKind::Spot {
                    inner_cone_angle,
                    outer_cone_angle,
                } => {
                    let light = GpuLight::spot(
                        l.position,
                        l.direction,
                        l.intensity,
                        inner_cone_angle,
                        outer_cone_angle,
                    );
                    let cone = 1.0 - 0.5 * f64::from(light.cos_inner + light.cos_outer);
                    (light, 2.0 * PI * cone * lum(l.intensity))
                }
                LightKind::Directional => (
                    GpuLight::directional(l.direction, l.intensity),
                    outside * lum(l.intensity),
                ),
            };
            lights.push(light);
            power.push(p);
        }
        let header_len = scene.instances.len().max(1);
        let mut header = vec![NONE; header_len];
        let mut runs: Vec<u32> = Vec::new();
        for t in &scene.emissive_triangles {
            let instance = &scene.instances[t.instance as usize];
            let mesh = &scene.meshes[instance.mesh as usize];
            let double_sided = mesh
                .materials
                .get(t.primitive as usize)
                .and_then(|&m| scene.materials.get(m as usize))
                .is_some_and(|m| m.double_sided);
            // The front is counter-clockwise in object space; a mirroring transform reverses
            // the world-space winding the light's vertices have.
            let sides = if double_sided {
                EMIT_FRONT | EMIT_BACK
            } else if instance.is_mirrored() {
                EMIT_BACK
            } else {
                EMIT_FRONT
            };
            let index = lights.len() as u32;
            lights.push(GpuLight::triangle(
                t.instance,
                t.primitive,
                t.vertices,
                t.emission,
                sides,
            ));
            power.push(PI * lum(t.emission) * f64::from(t.area) * f64::from(sides.count_ones()));
            let slot = &mut header[t.instance as usize];
            if *slot == NONE {
                *slot = (header_len + runs.len()) as u32;
                runs.extend(std::iter::repeat_n(NONE, mesh.triangles.len()));
            }
            let at = *slot as usize - header_len + t.primitive as usize;
            runs[at] = index;
        }
        let mut environment_light = NONE;
        if let Some(e) = environment.as_ref().filter(|_| sample_environment) {
            environment_light = lights.len() as u32;
            lights.push(GpuLight::ENVIRONMENT);
            power.push(outside * e.luminance_integral);
        }
        build_alias_table(&mut lights, &power);
        let mut clusters = vec![LightCluster::default(); LIGHT_GRID_MAX_CLUSTERS as usize];
        let count = build_light_clusters(&mut lights, &mut clusters);
        clusters.truncate(count as usize);
        header.extend(runs);
        Self {
            lights,
            triangle_table: header,
            environment,
            environment_light,
            clusters,
        }
    }

    /// The lights' part of the kernel's parameters.
    pub fn params(&self) -> LightParams {
        LightParams {
            count: self.lights.len() as u32,
            environment_size: self.environment.as_ref().map_or([0; 2], |e| e.size),
            environment_light: self.environment_light,
        }
    }
}

/// Fills the selection probabilities and the alias table (Vose's method, in f64) of `lights`
/// from their `power`; uniform when no light has a positive finite power.
fn build_alias_table(lights: &mut [GpuLight], power: &[f64]) {
    let n = lights.len();
    if n == 0 {
        return;
    }
    let clean: Vec<f64> = power
        .iter()
        .map(|&p| if p.is_finite() && p > 0.0 { p } else { 0.0 })
        .collect();
    let total: f64 = clean.iter().sum();
    let pmf: Vec<f64> = if total > 0.0 && total.is_finite() {
        clean.iter().map(|p| p / total).collect()
    } else {
        vec![1.0 / n as f64; n]
    };
    let mut scaled: Vec<f64> = pmf.iter().map(|p| p * n as f64).collect();
    let (mut small, mut large): (Vec<usize>, Vec<usize>) = (0..n).partition(|&i| scaled[i] < 1.0);
    for (light, p) in lights.iter_mut().zip(&pmf) {
        light.select_pmf = *p as f32;
        light.alias_threshold = 1.0;
    }
    while let (Some(&s), Some(&l)) = (small.last(), large.last()) {
        small.pop();
        lights[s].alias_threshold = scaled[s] as f32;
        lights[s].alias = l as u32;
        scaled[l] -= 1.0 - scaled[s];
        if scaled[l] < 1.0 {
            large.pop();
            small.push(l);
        }
    }
    // What rounding leaves in either list keeps its own column.
    for i in small.into_iter().chain(large) {
        lights[i].alias_threshold = 1.0;
        lights[i].alias = i as u32;
    }
}

/// The emitters on the device: lights, the triangle→light table, the environment's texels and
/// distribution, the light clusters (one-element placeholders where the scene has none).
pub struct GpuLights {
    lights: Buffer,
    triangle_table: Buffer,
    environment: Buffer,
    distribution: Buffer,
    clusters: Buffer,
    params: LightParams,
    /// What `lights` holds, to find what a new pose changed ([`GpuLights::stage_pose`]).
    uploaded: Vec<GpuLight>,
    /// What `clusters` holds.
    uploaded_clusters: Vec<LightCluster>,
    triangle_table_len: usize,
}

impl GpuLights {
    /// Bytes of device memory: lights, triangle table, environment and its distribution, light
    /// clusters.
    pub fn bytes(&self) -> u64 {
        [
            &self.lights,
            &self.triangle_table,
            &self.environment,
            &self.distribution,
            &self.clusters,
        ]
        .iter()
        .map(|b| b.size)
        .sum()
    }

    /// Uploads `set` to device-local memory.
    pub fn new(ctx: &Context, set: &LightSet) -> Result<Self> {
        let usage = vk::BufferUsageFlags::empty();
        let placeholder_light = [GpuLight::ZERO];
        let lights: &[GpuLight] = if set.lights.is_empty() {
            &placeholder_light
        } else {
            &set.lights
        };
        let placeholder_cluster = [LightCluster::default()];
        let clusters: &[LightCluster] = if set.clusters.is_empty() {
            &placeholder_cluster
        } else {
            &set.clusters
        };
        let placeholder_texel = [[0.0f32; 4]];
        let placeholder_cdf = [0.0f32];
        let (texels, cdf): (&[[f32; 4]], &[f32]) = match &set.environment {
            Some(e) => (&e.texels, &e.distribution),
            None => (&placeholder_texel, &placeholder_cdf),
        };
        Ok(Self {
            lights: Buffer::device_local(ctx, "lights", lights, usage)?,
            triangle_table: Buffer::device_local(ctx, "light table", &set.triangle_table, usage)?,
            environment: Buffer::device_local(ctx, "environment", texels, usage)?,
            distribution: Buffer::device_local(ctx, "environment distribution", cdf, usage)?,
            clusters: Buffer::device_local(ctx, "light clusters", clusters, usage)?,
            params: set.params(),
            uploaded: set.lights.clone(),
            uploaded_clusters: set.clusters.clone(),
            triangle_table_len: set.triangle_table.len(),
        })
    }

    /// Queues in `writes` the lights of `set` (the same scene's, made after it moved) that differ
    /// from those on the device, as one run from the first to the last that changed, and the
    /// same for the light clusters (whose bounds follow the lights); returns how many lights and
    /// clusters those runs hold (0 when none changed). The triangle→light table and the
    /// environment depend on the scene's meshes, materials and sky, not on its pose: they are
    /// not written again.
    ///
    /// Errors when `set` does not match the uploaded lights in count, environment or table size
    /// (made from another scene or sky: upload it anew).
    pub fn stage_pose<'a>(
        &'a mut self,
        set: &LightSet,
        writes: &mut StagedWrites<'a>,
    ) -> Result<[u32; 2]> {
        if set.params() != self.params || set.triangle_table.len() != self.triangle_table_len {
            return Err(Error::InvalidArgument {
                name: "lights",
                why: format!(
                    "{:?} with a table of {} entries, but the device holds {:?} with {}: lights \
                     of another scene or sky need a new upload",
                    set.params(),
                    set.triangle_table.len(),
                    self.params,
                    self.triangle_table_len
                ),
            });
        }
        // Same count of lights, same count of clusters (they follow from it).
        let clusters = stage_changes(
            &mut self.uploaded_clusters,
            &set.clusters,
            &self.clusters,
            writes,
        )?;
        let lights = stage_changes(&mut self.uploaded, &set.lights, &self.lights, writes)?;
        Ok([lights, clusters])
    }

    /// Number of lights (0 with the placeholder).
    pub fn count(&self) -> u32 {
        self.params.count
    }

    /// The lights' part of the kernel's parameters.
    pub fn params(&self) -> LightParams {
        self.params
    }

    /// The four buffers, the last bindings of the scene's set 2 (`vulkan::SceneSet::Shading`):
    /// lights, triangle→light table, environment texels, environment distribution.
    pub fn resources(&self) -> [Resource<'_>; 4] {
        self.buffers().map(Resource::Buffer)
    }

    /// The light clusters, which the light grid's build binds.
    pub fn clusters(&self) -> &Buffer {
        &self.clusters
    }

    /// The four buffers of [`Self::resources`], in its order.
    pub fn buffers(&self) -> [&Buffer; 4] {
        [
            &self.lights,
            &self.triangle_table,
            &self.environment,
            &self.distribution,
        ]
    }
}

/// Queues in `writes` the run of `now` from its first to its last element that differs from
/// `uploaded` (which then holds `now`), written to `buffer` at its place; returns its length (0
/// when nothing changed). `now` and `uploaded` have the same length.
fn stage_changes<'a, T: bytemuck::Pod>(
    uploaded: &mut [T],
    now: &[T],
    buffer: &'a Buffer,
    writes: &mut StagedWrites<'a>,
) -> Result<u32> {
    let same = |(a, b): (&T, &T)| bytemuck::bytes_of(a) == bytemuck::bytes_of(b);
    let pairs = || now.iter().zip(uploaded.iter());
    let Some(first) = pairs().position(|p| !same(p)) else {
        return Ok(0);
    };
    let last = pairs().rposition(|p| !same(p)).unwrap_or(first);
    let changed = &now[first..=last];
    uploaded[first..=last].copy_from_slice(changed);
    writes.write(buffer, (first * size_of::<T>()) as u64, changed)?;
    Ok(changed.len() as u32)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::test_scene;
    use gi_shared::lights::{light_of_triangle, select_light};
    use glam::Vec2;

    /// The alias table gives every light its probability, whatever the spread of powers.
    #[test]
    fn the_alias_table_follows_power() {
        for power in [
            vec![1.0, 2.0, 3.0, 4.0],
            vec![1e-6, 1e6, 0.0, 5.0, 5.0],
            vec![7.0],
            vec![0.0, 0.0],
            vec![f64::NAN, 1.0, f64::INFINITY],
        ] {
            let mut lights = vec![GpuLight::ZERO; power.len()];
            build_alias_table(&mut lights, &power);
            let n = lights.len();
            // Exact selection probability of each light: each column is chosen with 1/n.
            let mut p = vec![0.0f64; n];
            for (i, l) in lights.iter().enumerate() {
                let t = f64::from(l.alias_threshold).min(1.0);
                p[i] += t / n as f64;
                p[l.alias as usize] += (1.0 - t) / n as f64;
            }
            let sum: f64 = lights.iter().map(|l| f64::from(l.select_pmf)).sum();
            assert!((sum - 1.0).abs() < 1e-6, "{power:?}");
            for (i, l) in lights.iter().enumerate() {
                assert!(
                    (p[i] - f64::from(l.select_pmf)).abs() < 1e-6,
                    "{power:?}: light {i}: {} vs {}",
                    p[i],
                    l.select_pmf
                );
            }
            // Sampled, too.
            let mut counts = vec![0u32; n];
            let mut rng = gi_shared::random::Random::new(5, 0);
            for _ in 0..50_000 {
                counts[select_light(&lights, n as u32, rng.next_vec2()) as usize] += 1;
            }
            for (c, l) in counts.iter().zip(&lights) {
                let got = f64::from(*c) / 50_000.0;
                let q = f64::from(l.select_pmf);
                assert!((got - q).abs() <= 4.0 * (q * (1.0 - q) / 50_000.0).sqrt() + 1e-9);
            }
        }
    }

    /// Every emissive triangle of the Cornell box is found through the table, nothing else is.
    #[test]
    fn the_triangle_table_finds_every_light() {
        let scene = test_scene("cornell-box.gltf");
        let set = LightSet::new(&scene, None, true);
        assert_eq!(set.environment_light, NONE);
        assert_eq!(set.lights.len(), scene.emissive_triangles.len());
        for (i, t) in scene.emissive_triangles.iter().enumerate() {
            assert_eq!(
                light_of_triangle(&set.triangle_table, t.instance, t.primitive),
                i as u32
            );
        }
        let lights = scene.emissive_triangles.len();
        let mut found = 0;
        for (instance, inst) in scene.instances.iter().enumerate() {
            for p in 0..scene.meshes[inst.mesh as usize].triangles.len() {
                found += usize::from(
                    light_of_triangle(&set.triangle_table, instance as u32, p as u32) != NONE,
                );
            }
        }
        assert_eq!(found, lights);
    }

    /// An environment gets a light of its own when sampled, with a power that grows with it.
    #[test]
    fn the_environment_is_a_light_when_sampled() {
        let scene = test_scene("cornell-box.gltf");
        let env = Environment::new([8, 16], vec![[1.0, 1.0, 1.0, 0.0]; 128]).unwrap();
        let sampled = LightSet::new(&scene, Some(env.clone()), true);
        assert_eq!(sampled.environment_light as usize, sampled.lights.len() - 1);
        assert_eq!(sampled.params().environment_size, [8, 16]);
        // A uniform unit environment: ∫ L dω = 4π (the rows' midpoint rule, within 1%).
        assert!((env.luminance_integral / (4.0 * PI) - 1.0).abs() < 0.01);
        let unsampled = LightSet::new(&scene, Some(env), false);
        assert_eq!(unsampled.environment_light, NONE);
        assert_eq!(unsampled.lights.len(), sampled.lights.len() - 1);
        assert!(Environment::new([3, 2], vec![[0.0; 4]; 5]).is_err());
        assert!(Environment::new([0, 0], vec![]).is_err());
        let black = Environment::new([2, 2], vec![[0.0; 4]; 4]).unwrap();
        // A black image still has a valid (uniform) distribution.
        let s = gi_shared::environment::sample_environment(
            glam::UVec2::new(2, 2),
            black.distribution(),
            Vec2::splat(0.3),
        );
        assert!(s.pdf > 0.0);
    }

    /// A constant sky becomes a uniform image of its radiance, sampled like any environment.
    #[test]
    fn a_constant_sky_is_a_uniform_environment() {
        let env = Environment::constant(Vec3::new(0.5, 1.0, 2.0)).unwrap();
        assert_eq!(env.size(), CONSTANT_SKY_SIZE);
        assert!(env.texels().iter().all(|t| *t == [0.5, 1.0, 2.0, 0.0]));
        let l = f64::from(luminance(Vec3::new(0.5, 1.0, 2.0)));
        assert!((env.luminance_integral / (4.0 * PI * l) - 1.0).abs() < 0.01);
    }
}
