//! Which triangles are lights, and with what radiance: the emission a triangle really has.
//!
//! A material's `emissiveFactor` is multiplied by its emissive texture. A triangle of an emissive
//! material is a light with the factor times the texture's average over the triangle's UV
//! footprint ([`triangle_emission`]), and no light at all where that average is black. Taking the
//! factor alone made every triangle of a mostly black emissive texture a light as bright as its
//! brightest texel: a public sample scene with one such material made 88,837 of its 108,936
//! triangles lights, the light grid's build took 97 % of the frame, and light sampling (which
//! uses a light's stored radiance) lit the scene with light those triangles do not emit.
//!
//! # The average
//!
//! The triangle is split into `SUBDIVISIONS²` equal triangles (`SUBDIVISIONS` steps along each
//! edge), and the texture is read at each one's centroid with the shading's own filter
//! ([`gi_shared::textures::sample_mips`]) at the mip level where those points are at most one
//! texel apart: every texel under the triangle then weighs in through the mip chain, whatever the
//! triangle's size, at a fixed cost of `SUBDIVISIONS²` trilinear reads per triangle. That level's
//! filter reaches about `1 / SUBDIVISIONS` of the triangle past its edges, so where the reads
//! differ by more than a factor of 2 (the texture changes at the triangle's scale) the triangle is
//! read again with `FINE_SUBDIVISIONS²` reads. A triangle whose lit half ends at its edge reads
//! 0.95 of its emission (0.83 from the coarse reads alone), its black neighbour 0.04.
//!
//! A texel that emits inside a black region of `4^l` texels rounds away at level `l ≥ 7` (its
//! share is below half of the smallest sRGB step): such a triangle emits less than 1/16384 of its
//! factor and is dropped. Light sampling uses this average as the light's radiance over the whole
//! triangle; what a ray that hits the triangle sees is still the texture itself.

use gi_shared::textures::{GpuTexture, sample_mips};
use glam::{Vec2, Vec3};

use super::{Material, Mesh};

/// Steps along each edge of a triangle: its texture average reads `SUBDIVISIONS²` points.
const SUBDIVISIONS: u32 = 8;
/// Steps along each edge where those reads differ by more than a factor of 2 in some channel.
const FINE_SUBDIVISIONS: u32 = 32;

/// One emissive texture's texels in the shading's layout (`gi_shared::textures`), offset 0.
#[derive(Clone, Debug)]
pub(crate) struct PackedTexture {
    entry: GpuTexture,
    texels: Vec<u32>,
}

impl PackedTexture {
    /// Packs `texture` alone.
    pub(crate) fn new(texture: &super::Texture) -> Self {
        let mut texels = Vec::new();
        let entry = super::gpu_data::push_texture(texture, 0, &mut texels);
        Self { entry, texels }
    }
}

/// The radiance a triangle of `mesh` (vertex indices `triangle`) with `material` emits on
/// average: the material's factor times its emissive texture's mean over the triangle's UV
/// footprint (see the [module](self)); the factor alone without an emissive texture. `texture`
/// is the material's emissive texture, packed. A mesh without UVs reads the texture at (0, 0),
/// as shading does.
pub(crate) fn triangle_emission(
    material: &Material,
    texture: Option<&PackedTexture>,
    mesh: &Mesh,
    triangle: [u32; 3],
) -> Vec3 {
    let Some(t) = texture else {
        return material.emissive;
    };
    let uv = triangle.map(|v| {
        mesh.uvs
            .as_ref()
            .and_then(|uvs| uvs.get(v as usize).copied())
            .unwrap_or_default()
    });
    let coarse = texture_mean(t, uv, SUBDIVISIONS);
    // Where the texture changes at the triangle's scale, the coarse level's filter reaches
    // across the triangle's edges: read it again at a finer level.
    let mean = if coarse.min.cmplt(coarse.max * 0.5).any() {
        texture_mean(t, uv, FINE_SUBDIVISIONS).mean
    } else {
        coarse.mean
    };
    material.emissive * mean
}

/// A triangle's texture reads: their mean, and each channel's least and largest.
struct TextureMean {
    mean: Vec3,
    min: Vec3,
    max: Vec3,
}

/// `t`'s mean over the UV triangle `uv` from `subdivisions²` reads, one texel apart at their
/// level (see the [module](self)).
fn texture_mean(t: &PackedTexture, uv: [Vec2; 3], subdivisions: u32) -> TextureMean {
    let size = Vec2::new(t.entry.width as f32, t.entry.height as f32);
    let longest = [(0, 1), (1, 2), (2, 0)]
        .map(|(a, b)| ((uv[b] - uv[a]) * size).length())
        .into_iter()
        .fold(0.0f32, f32::max);
    let n = subdivisions as f32;
    // Points `longest / n` texels apart at level 0: one texel apart at this level.
    let lod = (longest / n).max(1.0).log2();
    let at = |b1: f32, b2: f32| uv[0] + (uv[1] - uv[0]) * (b1 / n) + (uv[2] - uv[0]) * (b2 / n);
    let mut out = TextureMean {
        mean: Vec3::ZERO,
        min: Vec3::INFINITY,
        max: Vec3::ZERO,
    };
    let mut read = |b1: f32, b2: f32| {
        let c = sample_mips(&t.entry, &t.texels, at(b1, b2), lod).truncate();
        out.mean += c;
        out.min = out.min.min(c);
        out.max = out.max.max(c);
    };
    for i in 0..subdivisions {
        for j in 0..subdivisions - i {
            let (fi, fj) = (i as f32, j as f32);
            // The sub-triangle pointing like the triangle, then (where there is one) the one
            // pointing the other way: equal areas, so equal weights.
            read(fi + 1.0 / 3.0, fj + 1.0 / 3.0);
            if i + j + 1 < subdivisions {
                read(fi + 2.0 / 3.0, fj + 2.0 / 3.0);
            }
        }
    }
    out.mean /= n * n;
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Instance, Scene, Texture, Wrap, mip_chain};
    use glam::Mat4;

    /// A `size × size` sRGB texture, white where `lit(x, y)`, black elsewhere.
    fn texture(size: u32, lit: impl Fn(u32, u32) -> bool) -> Texture {
        let level0 = (0..size * size)
            .flat_map(|i| {
                let v = if lit(i % size, i / size) { 255 } else { 0 };
                [v, v, v, 255]
            })
            .collect();
        Texture {
            name: "emission".to_owned(),
            width: size,
            height: size,
            levels: mip_chain::mip_chain(level0, size, size, true),
            srgb: true,
            wrap: [Wrap::Repeat; 2],
        }
    }

    /// Two triangles making the unit square in the plane z = 0, UVs from 0 to `tiles`, with an
    /// emissive material of factor 2 and `texture`.
    fn square(texture: Texture, tiles: f32) -> Scene {
        let mesh = Mesh {
            name: "square".to_owned(),
            positions: vec![
                Vec3::ZERO,
                Vec3::new(1.0, 0.0, 0.0),
                Vec3::new(1.0, 1.0, 0.0),
                Vec3::new(0.0, 1.0, 0.0),
            ],
            normals: vec![Vec3::Z; 4],
            uvs: Some(vec![
                Vec2::ZERO,
                Vec2::new(tiles, 0.0),
                Vec2::new(tiles, tiles),
                Vec2::new(0.0, tiles),
            ]),
            triangles: vec![[0, 1, 2], [0, 2, 3]],
            materials: vec![0, 0],
        };
        let material = Material {
            emissive: Vec3::splat(2.0),
            emissive_texture: Some(0),
            ..Material::default()
        };
        let instance = Instance {
            name: "square".to_owned(),
            node: 0,
            mesh: 0,
            transform: Mat4::IDENTITY,
        };
        Scene::from_parts(
            "square",
            vec![mesh],
            vec![instance],
            vec![material],
            vec![texture],
            Vec::new(),
        )
    }

    /// A black emissive texture makes no lights, whatever the factor.
    #[test]
    fn black_emission_makes_no_lights() {
        assert!(
            square(texture(64, |_, _| false), 1.0)
                .emissive_triangles
                .is_empty()
        );
    }

    /// Lit below the diagonal x = y (texel centres), black above: the worst case of the filter's
    /// reach across an edge. The triangle under the lit half reads 0.952 of the factor, the other
    /// 0.044 (at 8 subdivisions alone, 0.83).
    #[test]
    fn each_triangle_gets_the_emission_under_it() {
        let scene = square(texture(256, |x, y| y < x), 1.0);
        let lights = &scene.emissive_triangles;
        let [lit, dark] = [0, 1].map(|p| {
            lights
                .iter()
                .find(|l| l.primitive == p)
                .map_or(0.0, |l| l.emission.x)
        });
        assert!((lit - 2.0).abs() < 0.06 * 2.0, "{lit}");
        assert!(dark < 0.06 * 2.0, "{dark}");
    }

    /// A fine checker (1/8 of the texels lit), tiled 10 times over each triangle: each emits
    /// its mean, 1/8 of the factor, read from a coarse level.
    #[test]
    fn a_tiled_texture_emits_its_mean() {
        let scene = square(texture(64, |x, y| x % 4 == 0 && y % 2 == 0), 10.0);
        let lights = &scene.emissive_triangles;
        assert_eq!(lights.len(), 2);
        for l in lights {
            let expected = 2.0 / 8.0;
            assert!(
                (l.emission - Vec3::splat(expected)).abs().max_element() < 0.02 * expected,
                "{}",
                l.emission
            );
        }
    }

    /// A single lit texel among 64 × 64 black ones still makes a light of the triangle under it,
    /// and the lights' power (emission × area) is the texel's, 1/4096 of the square's factor.
    #[test]
    fn one_lit_texel_is_enough() {
        let scene = square(texture(64, |x, y| (x, y) == (40, 10)), 1.0);
        let lights = &scene.emissive_triangles;
        assert!(lights.iter().any(|l| l.primitive == 0), "{lights:?}");
        let power: f32 = lights.iter().map(|l| l.emission.x * l.area).sum();
        let share = power / 2.0 * 4096.0;
        assert!((0.8..1.2).contains(&share), "{share}");
    }

    /// Without an emissive texture the factor is the emission.
    #[test]
    fn the_factor_alone_without_a_texture() {
        let m = Material {
            emissive: Vec3::new(1.0, 2.0, 3.0),
            ..Material::default()
        };
        let mesh = square(texture(4, |_, _| true), 1.0).meshes.remove(0);
        assert_eq!(
            triangle_emission(&m, None, &mesh, [0, 1, 2]),
            Vec3::new(1.0, 2.0, 3.0)
        );
    }
}
