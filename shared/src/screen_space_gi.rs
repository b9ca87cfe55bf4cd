//! Screen-space GI (the talk's "use screen-space GI to recover small-scale details": probes cannot
//! capture detail smaller than about 20 pixels; horizon-based, Jimenez et al. 2016, "Practical
//! Realtime Strategies for Accurate Indirect Occlusion").
//!
//! Each pixel searches the depth buffer for the horizon on both sides of [`OCCLUSION_SLICES`]
//! screen-space slices, [`OCCLUSION_STEPS`] depth reads per side out to
//! [`HorizonSearch::radius`] pixels. Each slice's horizons give the cosine-weighted
//! visible share of the slice (the analytic slice integral, [`slice_arc`]) and the middle of its
//! visible arc. The result ([`Occlusion`]) is the cosine-weighted visibility of the hemisphere,
//! the bent normal (the mean direction it sees by) and the near-field light.
//! InterpolateScreenProbes reads the probes' SH through a cone around the bent normal whose
//! clamped-cosine lobe holds that visibility ([`Occlusion::lobe`], [`crate::sh::ShLobe::cone`], scaled by
//! [`hemisphere_cone_scale`] so that uniform light reads exactly), as the reference does, and
//! adds the near-field light: a crease or a contact shadow under an object loses the light from
//! the directions the nearby geometry hides, which the probes, 8 pixels apart, see past, and
//! gains the light that geometry reflects.
//!
//! Choices:
//! - The visibility is the ratio of the slices' visible to their unoccluded integrals, so a pixel
//!   whose horizons all lie at its tangent plane reads exactly 1 (and its irradiance is the
//!   plain cosine lobe, the same bits as without occlusion) whatever the slice count.
//! - Only samples above the tangent plane by more than [`OCCLUSION_TANGENT_BIAS`] (the sine of
//!   their elevation) raise a horizon, so a flat or tessellated plane does not occlude itself
//!   through depth rounding.
//! - A sample's horizon fades to nothing between [`OCCLUSION_FALLOFF_START`] × and 1 × the world
//!   radius (the search radius in pixels at the pixel's depth), so a distant wall behind a depth
//!   edge does not occlude.
//! - Near-field light: each sample that raises a horizon hides the arc between the old and the
//!   new horizon, and lights it with what its surface sent toward the eye in the previous frame
//!   ([`NearFieldSource`]; the reference reads its previous combined illumination). Its emission
//!   counts only where it faces the pixel, and only without emitter sampling, whose shadow rays
//!   already bring every emitter's light; its reflected light counts on either side (the far
//!   side's is unknown: it takes the near side's, as the reference does).
//! - The slices turn per pixel and frame (a low-discrepancy stream apart from the interpolation
//!   jitter's), and the denoiser averages them.
//!
//! Failure modes: what is off screen or behind the first depth layer does not occlude (a thin
//! pole occludes as if it were a wall behind it: a darker halo); the near-field light lags a
//! frame and is missing where the occluder was off screen last frame.

use glam::{UVec2, Vec3, Vec4};

use crate::camera::CameraParams;
use crate::math::{PI, acos, clamp, copysign, cos, max, min, saturate, sin};
use crate::primary_surface::primary_point;
use crate::random::pixel_sample;
use crate::sh::{ShLobe, hemisphere_cone_scale};

/// Screen-space slices per pixel and frame (the reference: 1).
pub const OCCLUSION_SLICES: u32 = 2;
/// Depth reads per side of each slice (the reference: 2).
pub const OCCLUSION_STEPS: u32 = 4;
/// Largest search radius in pixels [`HorizonSearch::radius`] may ask for.
pub const MAX_OCCLUSION_RADIUS_PIXELS: u32 = 64;
/// A sample raises its slice's horizon only when the sine of its elevation above the pixel's
/// tangent plane exceeds this (about 3°).
pub const OCCLUSION_TANGENT_BIAS: f32 = 0.05;
/// Share of the world radius beyond which a sample's horizon fades out, linearly to nothing at the
/// radius.
pub const OCCLUSION_FALLOFF_START: f32 = 0.5;
/// Added to the pixel's x before drawing its slice angles, so that their stream is not the
/// interpolation jitter's.
const OCCLUSION_STREAM: u32 = 0x5bd1_e995;

const HALF_PI: f32 = 0.5 * PI;

/// The occlusion of one pixel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Occlusion {
    /// Cosine-weighted visible share of the hemisphere, in `[0, 1]`; exactly 1 where nothing in
    /// reach rises above the tangent plane.
    pub visibility: f32,
    /// Unit direction of the visible cone's axis (the shading normal where nothing occludes).
    pub bent_normal: Vec3,
    /// Irradiance from the occluders' own light (the near-field term): what they sent toward
    /// the eye in the previous frame, over the share of the hemisphere they hide.
    pub near_field: Vec3,
    /// The factor on the probes' cone irradiance ([`hemisphere_cone_scale`] of the cone and
    /// the bent normal's angle from the shading normal); 1 where nothing occludes.
    pub cone_scale: f32,
}

impl Occlusion {
    /// Nothing occludes `normal`.
    #[inline]
    pub fn open(normal: Vec3) -> Self {
        Self {
            visibility: 1.0,
            bent_normal: normal,
            near_field: Vec3::ZERO,
            cone_scale: 1.0,
        }
    }

    /// Whether something occludes.
    #[inline]
    pub fn occluded(&self) -> bool {
        self.visibility < 1.0
    }

    /// The lobe the probes' SH is read through: the clamped cosine at the bent normal (the
    /// shading normal, where nothing occludes), else its cone of [`Self::cone_cos`] scaled by
    /// [`Self::cone_scale`].
    #[inline]
    pub fn lobe(&self) -> ShLobe {
        if self.occluded() {
            ShLobe::cone(self.bent_normal, self.cone_cos(), self.cone_scale)
        } else {
            ShLobe::cosine(self.bent_normal)
        }
    }

    /// The cosine of the half-angle of the cone whose clamped-cosine lobe holds
    /// [`Self::visibility`]: `sin² θ = visibility` (the reference's `acos(sqrt(1 − AO))`).
    #[inline]
    pub fn cone_cos(&self) -> f32 {
        crate::math::sqrt(saturate(1.0 - self.visibility))
    }
}

/// Linear depth of a pixel (0 or less: sky).
pub trait DepthSource {
    /// The depth of `pixel` (inside the image).
    fn depth_at(&self, pixel: UVec2) -> f32;
}

/// The albedo of the surface a pixel sees this frame.
pub trait AlbedoSource {
    /// The albedo at `pixel` (inside the image).
    fn albedo_at(&self, pixel: UVec2) -> Vec3;
}

/// The geometric normal of the surface a pixel sees this frame (facing the camera).
pub trait NormalSource {
    /// The unit normal at `pixel` (inside the image); zero for sky.
    fn normal_at(&self, pixel: UVec2) -> Vec3;
}

/// The light the surfaces on screen sent toward the eye in the previous frame: the near-field
/// term's source (the reference reads its previous combined illumination;
/// `crate::primary_lighting::PreviousLight` reads ResolveGI's inputs).
pub trait NearFieldSource {
    /// What the surface at world point `position`, whose albedo is `albedo`, sent toward the eye
    /// in the previous frame under `camera`'s previous view; zero where it is unknown. A diffuse
    /// surface sends the same toward its neighbours; `facing` says whether the pixel lies on the
    /// side the camera sees (a one-sided emitter's light reaches only that side; the other
    /// side's reflected light is unknown and taken as the same).
    fn radiance(&self, camera: &CameraParams, albedo: Vec3, position: Vec3, facing: bool) -> Vec3;

    /// Whether [`Self::radiance`] looks at `facing` (else the normal is not read).
    fn uses_facing(&self) -> bool;
}

/// No near-field light (the CPU model of interpolation, and tests).
#[derive(Clone, Copy, Debug)]
pub struct NoNearField;

impl NearFieldSource for NoNearField {
    #[inline]
    fn radiance(&self, _: &CameraParams, _: Vec3, _: Vec3, _: bool) -> Vec3 {
        Vec3::ZERO
    }

    #[inline]
    fn uses_facing(&self) -> bool {
        false
    }
}

/// Where and how far a frame's horizon search looks.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HorizonSearch {
    /// Search radius in pixels (`GiFrameParams::occlusion_radius`; at most
    /// [`MAX_OCCLUSION_RADIUS_PIXELS`]); 0: no occlusion.
    pub radius: u32,
    /// The frame counter that turns the slices.
    pub frame_index: u32,
}

/// A `width`-wide row-major image on the CPU (the CPU model's and the tests' sources): depths
/// (`f32`), G-buffer normal texels (`Vec4`, `xyz` the normal) or albedos (`Vec3`).
pub struct RowMajor<'a, T> {
    /// The texels.
    pub texels: &'a [T],
    /// The image's width.
    pub width: u32,
}

impl<T: Copy> RowMajor<'_, T> {
    /// The texel of `pixel`; `outside` beyond the slice.
    #[inline]
    fn at(&self, pixel: UVec2, outside: T) -> T {
        let i = (pixel.y * self.width + pixel.x) as usize;
        if i < self.texels.len() {
            self.texels[i]
        } else {
            outside
        }
    }
}

impl DepthSource for RowMajor<'_, f32> {
    #[inline]
    fn depth_at(&self, pixel: UVec2) -> f32 {
        self.at(pixel, 0.0)
    }
}

impl NormalSource for RowMajor<'_, Vec4> {
    #[inline]
    fn normal_at(&self, pixel: UVec2) -> Vec3 {
        self.at(pixel, Vec4::ZERO).truncate().normalize_or_zero()
    }
}

impl AlbedoSource for RowMajor<'_, Vec3> {
    #[inline]
    fn albedo_at(&self, pixel: UVec2) -> Vec3 {
        self.at(pixel, Vec3::ZERO)
    }
}

/// The clamped-cosine integral around `gamma` (the projected normal's angle from the view
/// vector) from 0 to horizon angle `h`, times `|sin|` (the slice's measure): Jimenez et al.'s
/// `â(h)`; one side of a slice.
#[inline]
pub fn slice_arc(h: f32, gamma: f32) -> f32 {
    0.25 * (-cos(2.0 * h - gamma) + cos(gamma) + 2.0 * h * sin(gamma))
}

/// The occlusion of the pixel `pixel` at linear depth `depth` with unit geometric normal
/// `geometric` and shading normal `shading`, from `depths`; [`Occlusion::open`] for radius 0,
/// a sky pixel, or a normal facing away from the eye. `surfaces` are this frame's depth,
/// geometric normal and albedo images; the near-field term reads `light` for the samples that
/// raise a horizon.
#[allow(
    clippy::too_many_arguments,
    reason = "the pixel's own G-buffer values and its two sources"
)]
pub fn horizon_occlusion<
    D: DepthSource + ?Sized,
    N: NormalSource + ?Sized,
    A: AlbedoSource + ?Sized,
    L: NearFieldSource + ?Sized,
>(
    camera: &CameraParams,
    search: HorizonSearch,
    pixel: UVec2,
    depth: f32,
    geometric: Vec3,
    shading: Vec3,
    surfaces: (&D, &N, &A),
    light: &L,
) -> Occlusion {
    let (depths, normals, albedo) = surfaces;
    let open = Occlusion::open(shading);
    let radius = min(search.radius as f32, MAX_OCCLUSION_RADIUS_PIXELS as f32);
    let [width, height] = camera.image_size;
    if radius < 1.0 || depth.is_nan() || depth <= 0.0 || height == 0 {
        return open;
    }
    let p = primary_point(camera, pixel, depth);
    let v = (camera.position() - p).normalize_or_zero();
    let reach = radius * 2.0 * camera.tan_half_fov_y * depth / height as f32;
    if v == Vec3::ZERO || !reach.is_finite() || reach <= 0.0 || geometric.dot(v) <= 0.0 {
        return open;
    }
    let u = pixel_sample(
        UVec2::new(pixel.x.wrapping_add(OCCLUSION_STREAM), pixel.y),
        search.frame_index,
    );
    let mut seen = 0.0;
    let mut unoccluded = 0.0;
    let mut weight = 0.0;
    let mut bend = Vec3::ZERO;
    let mut occluded = false;
    let mut near = Vec3::ZERO;
    let mut s = 0;
    while s < OCCLUSION_SLICES {
        let phi = PI * (s as f32 + u.x) / OCCLUSION_SLICES as f32;
        let (sx, sy) = (cos(phi), sin(phi));
        // Pixel y grows downward.
        let screen = camera.right() * sx - camera.up() * sy;
        let d = (screen - v * screen.dot(v)).normalize_or_zero();
        let axis = d.cross(v);
        let projected = geometric - axis * geometric.dot(axis);
        let length = projected.length();
        if d != Vec3::ZERO && length > 1e-4 {
            let cos_gamma = (projected.dot(v) / length).clamp(-1.0, 1.0);
            let gamma = copysign(acos(cos_gamma), projected.dot(d));
            let low = gamma - HALF_PI;
            let high = gamma + HALF_PI;
            // Highest cosine from the view vector on the −d and the +d side.
            let mut horizon = [-1.0f32; 2];
            let mut side = 0;
            while side < 2 {
                let sign = if side == 0 { -1.0 } else { 1.0 };
                let mut k = 0;
                while k < OCCLUSION_STEPS {
                    let r = (k as f32 + u.y) * radius / OCCLUSION_STEPS as f32;
                    let x = pixel.x as f32 + 0.5 + sign * sx * r;
                    let y = pixel.y as f32 + 0.5 + sign * sy * r;
                    if x >= 0.0 && y >= 0.0 && x < width as f32 && y < height as f32 {
                        let q = UVec2::new(x as u32, y as u32);
                        let qd = depths.depth_at(q);
                        if q != pixel && qd > 0.0 {
                            let w = primary_point(camera, q, qd) - p;
                            let dist = w.length();
                            if dist > 0.0 && w.dot(geometric) > OCCLUSION_TANGENT_BIAS * dist {
                                let fade = saturate(
                                    (reach - dist) / ((1.0 - OCCLUSION_FALLOFF_START) * reach),
                                );
                                let c = -1.0 + (w.dot(v) / dist + 1.0) * fade;
                                if c > horizon[side] {
                                    // The arc this sample newly hides sees its surface.
                                    let old = clamp(sign * acos(horizon[side]), low, high);
                                    let new = clamp(sign * acos(c), low, high);
                                    let arc = slice_arc(old, gamma) - slice_arc(new, gamma);
                                    if arc > 0.0 {
                                        let facing = light.uses_facing()
                                            && normals.normal_at(q).dot(w) < 0.0;
                                        let a = albedo.albedo_at(q);
                                        let l = light.radiance(camera, a, p + w, facing);
                                        near += l * (arc * length);
                                    }
                                    horizon[side] = c;
                                }
                            }
                        }
                    }
                    k += 1;
                }
                side += 1;
            }
            let h0 = max(-acos(horizon[0]), low);
            let h1 = min(acos(horizon[1]), high);
            let open_slice = slice_arc(low, gamma) + slice_arc(high, gamma);
            unoccluded += length * open_slice;
            weight += length;
            if h0 > low || h1 < high {
                occluded = true;
                seen += length * (slice_arc(h0, gamma) + slice_arc(h1, gamma));
                let middle = 0.5 * (h0 + h1);
                let toward = v * cos(middle) + d * sin(middle);
                bend += (toward - projected / length) * length;
            } else {
                seen += length * open_slice;
            }
        }
        s += 1;
    }
    if !occluded || unoccluded <= 0.0 || weight <= 0.0 {
        return open;
    }
    let visibility = saturate(seen / unoccluded);
    let bent_normal = (shading + bend / weight).normalize_or_zero();
    if !visibility.is_finite() || bent_normal == Vec3::ZERO {
        return open;
    }
    let near_field = near * (PI / unoccluded);
    let visibility = min(visibility, 1.0);
    let mut occlusion = Occlusion {
        visibility,
        bent_normal,
        near_field: if near_field.is_finite() {
            near_field.max(Vec3::ZERO)
        } else {
            Vec3::ZERO
        },
        cone_scale: 1.0,
    };
    occlusion.cone_scale = hemisphere_cone_scale(occlusion.cone_cos(), bent_normal.dot(shading));
    occlusion
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::CameraParams;

    const NO_NORMALS: RowMajor<'static, Vec4> = RowMajor {
        texels: &[],
        width: 0,
    };
    const NO_ALBEDO: RowMajor<'static, Vec3> = RowMajor {
        texels: &[],
        width: 0,
    };

    fn camera(width: u32, height: u32) -> CameraParams {
        let eye = Vec3::new(0.0, 1.0, 3.0);
        CameraParams::new(eye, -eye, Vec3::Y, 1.0, width, height)
    }

    fn search(radius: u32) -> HorizonSearch {
        HorizonSearch {
            radius,
            frame_index: 0,
        }
    }

    /// Linear depths of a scene of planes `(normal, offset)` (`n · x = offset`, seen from the
    /// side the camera is on), the nearest hit per pixel; and the normal hit.
    fn render(cam: &CameraParams, planes: &[(Vec3, f32)]) -> (Vec<f32>, Vec<Vec3>) {
        let [w, h] = cam.image_size;
        let mut depth = vec![0.0; (w * h) as usize];
        let mut normal = vec![Vec3::ZERO; (w * h) as usize];
        for y in 0..h {
            for x in 0..w {
                let ray = crate::camera::primary_ray(cam, UVec2::new(x, y), cam.jitter());
                let o = Vec3::from_array(ray.origin);
                let dir = Vec3::from_array(ray.direction);
                let mut best = f32::INFINITY;
                for &(n, c) in planes {
                    let t = (c - n.dot(o)) / n.dot(dir);
                    if t > 0.0 && t < best {
                        best = t;
                        normal[(y * w + x) as usize] = if n.dot(dir) < 0.0 { n } else { -n };
                    }
                }
                if best.is_finite() {
                    depth[(y * w + x) as usize] = best * dir.dot(cam.forward());
                }
            }
        }
        (depth, normal)
    }

    #[test]
    fn the_slice_integral_is_the_clamped_cosine_measure() {
        // â(h) = ∫ from 0 to h of cos(θ − γ) |sin θ| dθ (signed by the side), by the midpoint rule.
        for gamma in [-1.2f32, -0.4, 0.0, 0.3, 1.1] {
            for h in [-1.0f32, 0.2, 0.9, gamma - HALF_PI, gamma + HALF_PI] {
                let n = 20_000;
                let numeric: f64 = (0..n)
                    .map(|i| {
                        let t = (h as f64) * (i as f64 + 0.5) / n as f64;
                        (t - gamma as f64).cos() * t.sin().abs() * (h as f64).abs() / n as f64
                    })
                    .sum();
                let analytic = slice_arc(h, gamma);
                assert!(
                    (analytic as f64 - numeric).abs() < 1e-5,
                    "γ {gamma} h {h}: {analytic} vs {numeric}"
                );
            }
        }
    }

    #[test]
    fn an_open_plane_is_open_to_the_bit() {
        let cam = camera(64, 48);
        let (depth, normal) = render(&cam, &[(Vec3::Y, 0.0)]);
        let depths = RowMajor {
            texels: &depth,
            width: 64,
        };
        let f = search(16);
        let mut floor = 0;
        for y in 0..48 {
            for x in 0..64 {
                let i = y * 64 + x;
                if depth[i] > 0.0 {
                    floor += 1;
                    let pixel = UVec2::new(x as u32, y as u32);
                    for frame_index in [0, 7] {
                        let g = HorizonSearch { frame_index, ..f };
                        let o = horizon_occlusion(
                            &cam,
                            g,
                            pixel,
                            depth[i],
                            normal[i],
                            normal[i],
                            (&depths, &NO_NORMALS, &NO_ALBEDO),
                            &NoNearField,
                        );
                        assert_eq!(o, Occlusion::open(normal[i]), "pixel {pixel}");
                    }
                }
            }
        }
        assert!(floor > 1000, "{floor}");
    }

    #[test]
    fn a_wall_occludes_the_floor_beside_it_and_bends_its_normal_away() {
        // A floor and a wall at z = -1 facing +z: floor pixels next to the wall see about half
        // of their hemisphere's cosine measure minus what the wall hides.
        let cam = camera(96, 72);
        let (depth, normal) = render(&cam, &[(Vec3::Y, 0.0), (Vec3::Z, -1.0)]);
        let depths = RowMajor {
            texels: &depth,
            width: 96,
        };
        let f = search(24);
        let mut near = Vec::new();
        let mut far = Vec::new();
        for y in 0..72u32 {
            for x in 0..96u32 {
                let i = (y * 96 + x) as usize;
                if depth[i] <= 0.0 || normal[i] != Vec3::Y {
                    continue;
                }
                let pixel = UVec2::new(x, y);
                let p = primary_point(&cam, pixel, depth[i]);
                let o = horizon_occlusion(
                    &cam,
                    f,
                    pixel,
                    depth[i],
                    Vec3::Y,
                    Vec3::Y,
                    (&depths, &NO_NORMALS, &NO_ALBEDO),
                    &NoNearField,
                );
                assert!((0.0..=1.0).contains(&o.visibility), "{o:?}");
                assert!((o.bent_normal.length() - 1.0).abs() < 1e-5);
                let gap = p.z + 1.0;
                if gap < 0.15 {
                    near.push(o);
                } else if gap > 1.5 {
                    far.push(o);
                }
            }
        }
        assert!(
            near.len() > 20 && far.len() > 20,
            "{} {}",
            near.len(),
            far.len()
        );
        let mean =
            |os: &[Occlusion]| os.iter().map(|o| o.visibility).sum::<f32>() / os.len() as f32;
        // A wall beside a point hides a quarter-space: the cosine-weighted visibility of a
        // hemisphere cut by a perpendicular plane through the point is 1/2.
        let (n, f) = (mean(&near), mean(&far));
        assert!((0.5..0.8).contains(&n), "near the wall {n}");
        assert!(f > 0.97, "away from the wall {f}");
        // White surfaces that sent 1 toward the eye: the occluders give back exactly what they
        // hide, π (1 − v).
        let albedo = vec![Vec3::ONE; 96 * 72];
        let white = RowMajor {
            texels: &albedo,
            width: 96,
        };
        let texels: Vec<Vec4> = normal.iter().map(|n| n.extend(1.0)).collect();
        let up = RowMajor {
            texels: &texels,
            width: 96,
        };
        struct Uniform;
        impl NearFieldSource for Uniform {
            fn radiance(&self, _: &CameraParams, albedo: Vec3, _: Vec3, facing: bool) -> Vec3 {
                assert!(facing, "the wall and the floor face each other");
                albedo
            }
            fn uses_facing(&self) -> bool {
                true
            }
        }
        let g = search(24);
        for y in (0..72u32).step_by(3) {
            for x in (0..96u32).step_by(3) {
                let i = (y * 96 + x) as usize;
                if depth[i] <= 0.0 {
                    continue;
                }
                let pixel = UVec2::new(x, y);
                let (d, n) = (depth[i], normal[i]);
                let lit =
                    horizon_occlusion(&cam, g, pixel, d, n, n, (&depths, &up, &white), &Uniform);
                let dark = horizon_occlusion(
                    &cam,
                    g,
                    pixel,
                    d,
                    n,
                    n,
                    (&depths, &NO_NORMALS, &NO_ALBEDO),
                    &NoNearField,
                );
                assert_eq!(dark.near_field, Vec3::ZERO);
                assert_eq!(
                    (lit.visibility, lit.bent_normal),
                    (dark.visibility, dark.bent_normal)
                );
                let hidden = PI * (1.0 - lit.visibility);
                assert!(
                    (lit.near_field - Vec3::splat(hidden)).abs().max_element() < 1e-5,
                    "{pixel}: {lit:?}"
                );
            }
        }
        // The bent normal leans away from the wall (+z).
        let lean = near.iter().map(|o| o.bent_normal.z).sum::<f32>() / near.len() as f32;
        assert!(lean > 0.1, "{lean}");
    }

    #[test]
    fn bad_inputs_read_open() {
        let cam = camera(16, 16);
        let depth = vec![1.0; 256];
        let depths = RowMajor {
            texels: &depth,
            width: 16,
        };
        let p = UVec2::new(8, 8);
        let n = Vec3::Z;
        for (f, d) in [
            (search(0), 1.0),
            (search(8), 0.0),
            (search(8), f32::NAN),
            (search(8), f32::INFINITY),
            (search(u32::MAX), 1e30),
        ] {
            let o = horizon_occlusion(
                &cam,
                f,
                p,
                d,
                n,
                n,
                (&depths, &NO_NORMALS, &NO_ALBEDO),
                &NoNearField,
            );
            assert!(o.visibility.is_finite() && (0.0..=1.0).contains(&o.visibility));
            assert!(o.bent_normal.is_finite());
        }
        let nan = vec![f32::NAN; 256];
        let nans = RowMajor {
            texels: &nan,
            width: 16,
        };
        let o = horizon_occlusion(
            &cam,
            search(8),
            p,
            1.0,
            n,
            n,
            (&nans, &NO_NORMALS, &NO_ALBEDO),
            &NoNearField,
        );
        assert_eq!(o, Occlusion::open(n));
    }
}
