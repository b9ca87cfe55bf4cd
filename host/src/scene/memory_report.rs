//! The scene's device memory by part, as `gi` prints it: what the geometry, its acceleration
//! structure, the textures and the lights cost.

use std::fmt;

/// Bytes of device memory of an uploaded scene, by part (`GpuScene::memory`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SceneMemory {
    /// Instances, meshes, vertices, triangles and materials (the shading data's buffers).
    pub geometry: u64,
    /// What tracing walks: the software BVH's buffers, or the bottom- and top-level acceleration
    /// structures.
    pub bvh: u64,
    /// The texture images with their mip chains, and the texture table.
    pub textures: u64,
    /// Lights, the triangle → light table, the environment and its distribution.
    pub lights: u64,
}

impl SceneMemory {
    /// All parts together.
    pub fn total(&self) -> u64 {
        self.geometry + self.bvh + self.textures + self.lights
    }
}

impl fmt::Display for SceneMemory {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mib = |b: u64| b as f64 / (1024.0 * 1024.0);
        write!(
            f,
            "geometry {:.1} MiB, BVH {:.1} MiB, textures {:.1} MiB, lights {:.1} MiB; total {:.1} MiB",
            mib(self.geometry),
            mib(self.bvh),
            mib(self.textures),
            mib(self.lights),
            mib(self.total())
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_total_adds_the_parts_and_prints_in_mib() {
        let m = SceneMemory {
            geometry: 3 << 20,
            bvh: 1 << 20,
            textures: 1 << 19,
            lights: 0,
        };
        assert_eq!(m.total(), (9 << 19) as u64);
        assert_eq!(
            m.to_string(),
            "geometry 3.0 MiB, BVH 1.0 MiB, textures 0.5 MiB, lights 0.0 MiB; total 4.5 MiB"
        );
    }
}
