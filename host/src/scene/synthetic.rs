//! Synthetic instanced scenes for scaling tests: a closed room lit by an emissive ceiling panel,
//! holding many instances of a few tessellated meshes, written as a GLB file.
//!
//! The unique meshes are UV spheres, tori and subdivided boxes in turn, each of its own colour,
//! with triangle counts spread geometrically between about 1% of the largest and the largest
//! (`min(100k, total / 16)`, at least 64). Instances stand on a square grid on the floor (1.2 m
//! pitch), each jittered, turned about +Y and scaled by a seeded generator, with a mesh drawn at
//! random, until the world triangle count (room and lamp included) reaches the request: the last
//! instances take the largest mesh that still fits, so the total overshoots by less than the
//! smallest mesh. The same parameters give the same file, byte for byte.
//!
//! The room grows with the grid; its ceiling is 3 m high, and the lamp, a quad facing down under
//! it, covers the middle quarter of the ceiling. A camera in a corner looks at the middle.

use glam::{Quat, Vec2, Vec3};
use serde_json::{Value, json};
use std::f32::consts::{PI, TAU};
use std::path::Path;

use crate::{Error, Result};

/// Fewest world triangles [`generate`] accepts.
pub const MIN_TRIANGLES: u64 = 1_000;
/// Most world triangles [`generate`] accepts: beyond, instance counts and the JSON grow past what
/// the renderer's 32-bit instance and triangle ids can name.
pub const MAX_TRIANGLES: u64 = 4_000_000_000;
/// Most unique meshes [`generate`] accepts.
pub const MAX_UNIQUE_MESHES: u32 = 64;
/// Triangles of the largest unique mesh, at most.
const MAX_MESH_TRIANGLES: u64 = 100_000;
/// Grid pitch, metres: objects are at most 1 m across.
const PITCH: f32 = 1.2;
/// Room height, metres.
const HEIGHT: f32 = 3.0;

/// What to generate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SyntheticParams {
    /// World triangles wanted, in [[`MIN_TRIANGLES`], [`MAX_TRIANGLES`]].
    pub triangles: u64,
    /// Distinct meshes, in [1, [`MAX_UNIQUE_MESHES`]].
    pub unique_meshes: u32,
    /// Seed of the placement and mesh choice.
    pub seed: u64,
}

impl Default for SyntheticParams {
    fn default() -> Self {
        Self {
            triangles: 1_000_000,
            unique_meshes: 4,
            seed: 1,
        }
    }
}

/// What [`generate`] made.
#[derive(Clone, Debug, PartialEq)]
pub struct SyntheticScene {
    /// The GLB file's bytes.
    pub glb: Vec<u8>,
    /// World triangles: every instance's, the room's and the lamp's.
    pub world_triangles: u64,
    /// Triangles stored once: the unique meshes', the room's and the lamp's.
    pub unique_triangles: u64,
    /// Object instances (the room and the lamp not counted).
    pub instances: u64,
    /// Inner extent of the room: x and z in [-half, half], y in [0, 3 m].
    pub room_half_width: f32,
}

/// Parses a count such as `10000`, `10k`, `1.5M` or `2G` (decimal: k = 10³, M = 10⁶, G = 10⁹).
pub fn parse_count(text: &str) -> std::result::Result<u64, String> {
    let text = text.trim();
    let (number, scale) = match text.char_indices().last() {
        Some((at, 'k' | 'K')) => (&text[..at], 1e3),
        Some((at, 'm' | 'M')) => (&text[..at], 1e6),
        Some((at, 'g' | 'G')) => (&text[..at], 1e9),
        _ => (text, 1.0),
    };
    let value: f64 = number
        .parse()
        .map_err(|_| format!("{text:?} is not a count (such as 10000, 10k, 1.5M)"))?;
    let count = value * scale;
    if !(count.is_finite() && count >= 0.0 && count <= u64::MAX as f64) {
        return Err(format!(
            "{text:?} is not a count (such as 10000, 10k, 1.5M)"
        ));
    }
    Ok(count.round() as u64)
}

/// Generates the scene in memory; see the [module](self).
pub fn generate(params: &SyntheticParams) -> Result<SyntheticScene> {
    if !(MIN_TRIANGLES..=MAX_TRIANGLES).contains(&params.triangles) {
        return Err(Error::InvalidArgument {
            name: "triangles",
            why: format!(
                "{}: a synthetic scene has {MIN_TRIANGLES} to {MAX_TRIANGLES} triangles",
                params.triangles
            ),
        });
    }
    if !(1..=MAX_UNIQUE_MESHES).contains(&params.unique_meshes) {
        return Err(Error::InvalidArgument {
            name: "unique-meshes",
            why: format!(
                "{}: a synthetic scene has 1 to {MAX_UNIQUE_MESHES} unique meshes",
                params.unique_meshes
            ),
        });
    }
    let mut rng = SplitMix64(params.seed);
    let largest = (params.triangles / 16).clamp(64, MAX_MESH_TRIANGLES);
    let smallest = (largest / 100).max(64);
    let meshes: Vec<Geometry> = (0..params.unique_meshes)
        .map(|i| {
            let f = match params.unique_meshes {
                1 => 1.0,
                n => i as f64 / (n - 1) as f64,
            };
            let budget = smallest as f64 * (largest as f64 / smallest as f64).powf(f);
            shape(i, budget as u64)
        })
        .collect();
    // Largest first, for the final fill.
    let mut by_size: Vec<usize> = (0..meshes.len()).collect();
    by_size.sort_by_key(|&m| std::cmp::Reverse(meshes[m].triangle_count()));

    let fixed = 12 + 2; // the room and the lamp
    let mut world = fixed;
    let mut placed_meshes = Vec::new();
    while world < params.triangles {
        let remaining = params.triangles - world;
        let pick = rng.below(meshes.len() as u64) as usize;
        let mesh = if meshes[pick].triangle_count() <= remaining {
            pick
        } else {
            // The largest that fits, else the smallest: overshoot below one smallest mesh.
            *by_size
                .iter()
                .find(|&&m| meshes[m].triangle_count() <= remaining)
                .unwrap_or(&by_size[by_size.len() - 1])
        };
        world += meshes[mesh].triangle_count();
        placed_meshes.push(mesh);
    }
    let side = (placed_meshes.len() as f64).sqrt().ceil().max(1.0) as usize;
    let half = 0.5 * side as f32 * PITCH + 1.0;

    let mut doc = GlbBuilder::default();
    let mut materials = vec![
        json!({"name": "walls", "pbrMetallicRoughness": {
            "baseColorFactor": [0.75, 0.75, 0.75, 1.0], "metallicFactor": 0.0}}),
        json!({"name": "lamp", "emissiveFactor": [1.0, 0.9, 0.75],
            "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 4.0}},
            "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1.0],
            "metallicFactor": 0.0}}),
    ];
    let mut gltf_meshes = vec![
        doc.mesh("room", &room(half), 0),
        doc.mesh("lamp", &lamp(half), 1),
    ];
    for (i, mesh) in meshes.iter().enumerate() {
        // Colours around the hue circle, by golden-ratio steps.
        let hue = (i as f32 * 0.618_034).fract();
        let [r, g, b] = hue_colour(hue);
        materials.push(
            json!({"name": format!("colour {i}"), "pbrMetallicRoughness": {
            "baseColorFactor": [r, g, b, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.8}}),
        );
        gltf_meshes.push(doc.mesh(&mesh.name, mesh, materials.len() - 1));
    }
    let mut nodes = vec![
        json!({"name": "room", "mesh": 0}),
        json!({"name": "lamp", "mesh": 1}),
    ];
    for (k, &mesh) in placed_meshes.iter().enumerate() {
        let (row, column) = (k / side, k % side);
        let jitter = Vec2::new(rng.unit(), rng.unit()) - 0.5;
        let x = (column as f32 + 0.5 + 0.3 * jitter.x) * PITCH - 0.5 * side as f32 * PITCH;
        let z = (row as f32 + 0.5 + 0.3 * jitter.y) * PITCH - 0.5 * side as f32 * PITCH;
        let scale = 0.6 + 0.4 * rng.unit();
        let turn = Quat::from_rotation_y(TAU * rng.unit());
        // Meshes span [-0.5, 0.5]: stand them on the floor.
        nodes.push(json!({
            "name": format!("object {k}"),
            "mesh": mesh + 2,
            "translation": [x, 0.5 * scale, z],
            "rotation": turn.to_array(),
            "scale": [scale, scale, scale],
        }));
    }
    let eye = Vec3::new(-half + 0.5, HEIGHT - 0.5, half - 0.5);
    let target = Vec3::new(0.0, 0.5, 0.0);
    let forward = (target - eye).normalize();
    let right = forward.cross(Vec3::Y).normalize();
    let up = right.cross(forward);
    let look = Quat::from_mat3(&glam::Mat3::from_cols(right, up, -forward)).normalize();
    nodes.push(
        json!({"name": "camera", "camera": 0, "translation": eye.to_array(),
        "rotation": look.to_array()}),
    );
    let unique = fixed + meshes.iter().map(Geometry::triangle_count).sum::<u64>();
    let json = json!({
        "asset": {"version": "2.0", "generator": "gi generate (gi_host::scene::synthetic)"},
        "extras": {"triangles": world, "unique_triangles": unique, "seed": params.seed},
        "extensionsUsed": ["KHR_materials_emissive_strength"],
        "scene": 0,
        "scenes": [{"name": "synthetic", "nodes": (0..nodes.len()).collect::<Vec<_>>()}],
        "nodes": nodes,
        "meshes": gltf_meshes,
        "materials": materials,
        "cameras": [{"type": "perspective", "perspective": {
            "yfov": 60f32.to_radians(), "aspectRatio": 16.0 / 9.0, "znear": 0.05}}],
        "accessors": doc.accessors,
        "bufferViews": doc.views,
        "buffers": [{"byteLength": doc.bin.len()}],
    });
    Ok(SyntheticScene {
        glb: glb(&json, &doc.bin),
        world_triangles: world,
        unique_triangles: unique,
        instances: placed_meshes.len() as u64,
        room_half_width: half,
    })
}

/// Generates the scene and writes it to `path` (a `.glb`).
pub fn write(params: &SyntheticParams, path: &Path) -> Result<SyntheticScene> {
    let scene = generate(params)?;
    std::fs::write(path, &scene.glb).map_err(|e| Error::Output {
        path: path.to_owned(),
        why: format!("cannot write it: {e}"),
    })?;
    Ok(scene)
}

/// A triangle mesh with normals, in [-0.5, 0.5]³.
struct Geometry {
    name: String,
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    indices: Vec<u32>,
}

impl Geometry {
    fn new(name: String) -> Self {
        Self {
            name,
            positions: Vec::new(),
            normals: Vec::new(),
            indices: Vec::new(),
        }
    }

    fn triangle_count(&self) -> u64 {
        self.indices.len() as u64 / 3
    }

    /// A grid of `(u + 1) × (v + 1)` vertices made by `vertex(s, t)` for s, t in [0, 1], two
    /// triangles per cell, counter-clockwise when `vertex`'s ∂/∂s × ∂/∂t faces out.
    fn grid(&mut self, u: u32, v: u32, vertex: impl Fn(f32, f32) -> (Vec3, Vec3)) {
        let base = self.positions.len() as u32;
        for j in 0..=v {
            for i in 0..=u {
                let (p, n) = vertex(i as f32 / u as f32, j as f32 / v as f32);
                self.positions.push(p);
                self.normals.push(n);
            }
        }
        for j in 0..v {
            for i in 0..u {
                let a = base + j * (u + 1) + i;
                let (b, c, d) = (a + 1, a + u + 1, a + u + 2);
                self.indices.extend_from_slice(&[a, b, d, a, d, c]);
            }
        }
    }
}

/// Unique mesh `i` of about `budget` triangles: a sphere, a torus or a box, in turn.
fn shape(i: u32, budget: u64) -> Geometry {
    let budget = budget.max(64) as f64;
    match i % 3 {
        0 => {
            // 2 u (v - 1) triangles, v = u / 2: about u².
            let u = (budget.sqrt() as u32).max(8);
            let mut g = Geometry::new(format!("sphere {i}"));
            sphere(&mut g, u, u / 2);
            g
        }
        1 => {
            // A torus of 2 u v triangles, u = 2 v.
            let v = (budget / 4.0).sqrt().max(3.0) as u32;
            let mut g = Geometry::new(format!("torus {i}"));
            g.grid(2 * v, v, |s, t| {
                let (a, b) = (TAU * s, TAU * t);
                let (major, minor) = (0.35, 0.15);
                let n = Vec3::new(a.cos() * b.cos(), b.sin(), -a.sin() * b.cos());
                let centre = Vec3::new(a.cos(), 0.0, -a.sin()) * major;
                (centre + n * minor, n)
            });
            g
        }
        _ => {
            // A box of 6 faces of n × n cells: 12 n² triangles.
            let n = (budget / 12.0).sqrt().max(1.0) as u32;
            let mut g = Geometry::new(format!("box {i}"));
            for axis in 0..3 {
                for sign in [-1.0f32, 1.0] {
                    let normal = Vec3::AXES[axis] * sign;
                    let tu = Vec3::AXES[(axis + 1) % 3] * sign;
                    let tv = Vec3::AXES[(axis + 2) % 3];
                    g.grid(n, n, |s, t| {
                        (0.5 * normal + (s - 0.5) * tu + (t - 0.5) * tv, normal)
                    });
                }
            }
            g
        }
    }
}

/// A UV sphere of radius 0.5 with `u` segments and `v` rings, without the degenerate triangles
/// at the poles: `2 u (v - 1)` triangles.
fn sphere(g: &mut Geometry, u: u32, v: u32) {
    let vertex = |s: f32, t: f32| {
        let (theta, phi) = (PI * t, TAU * s);
        let n = Vec3::new(
            theta.sin() * phi.cos(),
            theta.cos(),
            theta.sin() * phi.sin(),
        );
        (0.5 * n, n)
    };
    g.grid(u, v, vertex);
    // Each cell of the top row has a zero-area first triangle (two vertices at the pole), each
    // of the bottom row a zero-area second one: drop them.
    let cells = g.indices.len() / 6;
    let mut kept = Vec::with_capacity(g.indices.len());
    for (c, cell) in g.indices.as_chunks::<6>().0.iter().enumerate() {
        if c < u as usize {
            kept.extend_from_slice(&cell[3..]);
        } else if c >= cells - u as usize {
            kept.extend_from_slice(&cell[..3]);
        } else {
            kept.extend_from_slice(cell);
        }
    }
    g.indices = kept;
}

/// The room's six faces, facing in.
fn room(half: f32) -> Geometry {
    let mut g = Geometry::new("room".to_owned());
    let size = Vec3::new(2.0 * half, HEIGHT, 2.0 * half);
    let centre = Vec3::new(0.0, 0.5 * HEIGHT, 0.0);
    for axis in 0..3 {
        for sign in [-1.0f32, 1.0] {
            // Inward normal: facing -sign along the axis.
            let normal = -Vec3::AXES[axis] * sign;
            let tu = Vec3::AXES[(axis + 2) % 3] * sign;
            let tv = Vec3::AXES[(axis + 1) % 3];
            g.grid(1, 1, |s, t| {
                let p =
                    centre + 0.5 * size * (-normal) + (s - 0.5) * tu * size + (t - 0.5) * tv * size;
                (p, normal)
            });
        }
    }
    g
}

/// The lamp: a quad 1 cm under the ceiling, facing down, over the middle quarter of it.
fn lamp(half: f32) -> Geometry {
    let mut g = Geometry::new("lamp".to_owned());
    g.grid(1, 1, |s, t| {
        (
            Vec3::new((s - 0.5) * half, HEIGHT - 0.01, (t - 0.5) * half),
            Vec3::NEG_Y,
        )
    });
    g
}

/// A saturated, light colour of `hue` in [0, 1).
fn hue_colour(hue: f32) -> [f32; 3] {
    let channel = |offset: f32| {
        let x = ((hue + offset).fract() * 6.0 - 3.0).abs() - 1.0;
        0.15 + 0.65 * x.clamp(0.0, 1.0)
    };
    [channel(0.0), channel(2.0 / 3.0), channel(1.0 / 3.0)]
}

/// The buffer and the accessors over it, as the document is assembled.
#[derive(Default)]
struct GlbBuilder {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl GlbBuilder {
    fn accessor(&mut self, bytes: &[u8], count: usize, component: u32, ty: &str) -> usize {
        let extra = json!({});
        self.accessor_with(bytes, count, component, ty, extra)
    }

    fn accessor_with(
        &mut self,
        bytes: &[u8],
        count: usize,
        component: u32,
        ty: &str,
        mut accessor: Value,
    ) -> usize {
        self.views
            .push(json!({"buffer": 0, "byteOffset": self.bin.len(),
            "byteLength": bytes.len()}));
        self.bin.extend_from_slice(bytes);
        accessor["bufferView"] = json!(self.views.len() - 1);
        accessor["componentType"] = json!(component);
        accessor["count"] = json!(count);
        accessor["type"] = json!(ty);
        self.accessors.push(accessor);
        self.accessors.len() - 1
    }

    /// A glTF mesh of one primitive.
    fn mesh(&mut self, name: &str, g: &Geometry, material: usize) -> Value {
        const FLOAT: u32 = 5126;
        const UNSIGNED_INT: u32 = 5125;
        let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        for &p in &g.positions {
            (lo, hi) = (lo.min(p), hi.max(p));
        }
        let bounds = json!({"min": lo.to_array(), "max": hi.to_array()});
        let count = g.positions.len();
        let position = self.accessor_with(
            bytemuck::cast_slice(&g.positions),
            count,
            FLOAT,
            "VEC3",
            bounds,
        );
        let normal = self.accessor(bytemuck::cast_slice(&g.normals), count, FLOAT, "VEC3");
        let indices = self.accessor(
            bytemuck::cast_slice(&g.indices),
            g.indices.len(),
            UNSIGNED_INT,
            "SCALAR",
        );
        json!({"name": name, "primitives": [{
            "attributes": {"POSITION": position, "NORMAL": normal},
            "indices": indices,
            "material": material,
        }]})
    }
}

/// A GLB container of `json` and the binary chunk `bin` (each padded to 4 bytes).
fn glb(json: &Value, bin: &[u8]) -> Vec<u8> {
    let mut json_bytes = serde_json::to_vec(json).expect("a JSON value serialises");
    json_bytes.resize(json_bytes.len().next_multiple_of(4), b' ');
    let bin_length = bin.len().next_multiple_of(4);
    let total = 12 + 8 + json_bytes.len() + 8 + bin_length;
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json_bytes.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json_bytes);
    out.extend_from_slice(&(bin_length as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(bin);
    out.resize(total, 0);
    out
}

/// SplitMix64: a small, seedable generator, so that a seed gives the same scene everywhere.
struct SplitMix64(u64);

impl SplitMix64 {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    fn unit(&mut self) -> f32 {
        (self.next() >> 40) as f32 / (1u64 << 24) as f32
    }

    /// Uniform in [0, n).
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Signed volume enclosed by a closed mesh: positive when its triangles face out.
    fn volume(g: &Geometry) -> f64 {
        g.indices
            .as_chunks::<3>()
            .0
            .iter()
            .map(|t| {
                let [a, b, c] = [0, 1, 2].map(|k| g.positions[t[k] as usize]);
                f64::from(a.dot(b.cross(c))) / 6.0
            })
            .sum()
    }

    #[test]
    fn shapes_are_closed_face_out_and_near_their_budget() {
        let analytic = [
            4.0 / 3.0 * std::f64::consts::PI * 0.125, // sphere, r = 0.5
            2.0 * std::f64::consts::PI.powi(2) * 0.35 * 0.15f64.powi(2), // torus
            1.0,                                      // unit box
        ];
        for (i, expected) in analytic.into_iter().enumerate() {
            let g = shape(i as u32, 5000);
            let v = volume(&g);
            assert!(
                (v / expected - 1.0).abs() < 0.02,
                "shape {i}: {v} for {expected}"
            );
            let n = g.triangle_count();
            assert!(
                (3000..=5000).contains(&n),
                "shape {i}: {n} triangles for 5000"
            );
            // Normals point away from the centre (the torus: from its ring).
            for (p, n) in g.positions.iter().zip(&g.normals) {
                let centre = match i {
                    1 => Vec3::new(p.x, 0.0, p.z).normalize() * 0.35,
                    _ => Vec3::ZERO,
                };
                assert!((*p - centre).dot(*n) > 0.0, "shape {i} at {p}");
            }
        }
        // The room faces in: a negative volume, the room's.
        let v = volume(&room(2.0));
        assert!((v + 4.0 * 4.0 * 3.0).abs() < 1e-6, "{v}");
    }
}
