//! Light clusters: what the light grid's build weighs (`crate::light_grid`), so that its cost
//! per cell is bounded whatever the light count.
//!
//! Weighing every light for every cell cost `cells × lights`: 100,000 emissive triangles took
//! 2.4 s of a 2.7 s frame on lavapipe (320 × 180). The host groups the light list into at most
//! [`LIGHT_GRID_MAX_CLUSTERS`] clusters of consecutive lights ([`build_light_clusters`]); a cell
//! weighs each cluster once ([`cluster_weight`]) and draws a light inside the cluster it picked
//! by the lights' power ([`pick_in_cluster`]), so the build costs `cells × clusters + entries`.
//!
//! Up to [`LIGHT_GRID_MAX_CLUSTERS`] lights every light is a cluster of its own, weighed exactly
//! as before clusters existed. Beyond it:
//! * runs of consecutive lights of one size share a cluster (emissive triangles are consecutive
//!   in their mesh's leaf order, so a run is close together); near lights (point, spot,
//!   triangle), directional lights and the environment never share one, since a cluster draws its
//!   lights by power alone, and a directional light's irradiance is not comparable with a near
//!   light's power;
//! * a cluster's weight for a cell is its point, spot and triangle lights' power over the squared
//!   distance from the cell to the cluster's bounding box (at least half a cell, as for one
//!   light, and at least `r² / count`, `r` the box's half diagonal: a cell inside a wide cluster
//!   is near few of its lights), plus its directional lights' power;
//! * inside a cluster a light is drawn with probability `power / cluster power`
//!   ([`light_grid_power`]), from the cumulative sums the host stores in each light
//!   ([`GpuLight::cluster_cdf`]); uniformly where the cluster has no power.
//!
//! Each entry's probability stays exact (`crate::light_grid`'s unbiasedness): the cluster's share
//! of the cell's weights times the light's share of its cluster, plus the defensive floor.

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

use crate::color::luminance;
use crate::lights::{
    GpuLight, LIGHT_DIRECTIONAL, LIGHT_ENVIRONMENT, LIGHT_POINT, LIGHT_SPOT, LIGHT_TRIANGLE,
};
use crate::math::{PI, max, min, min_u32, positive_or_zero};

/// Most clusters the light grid weighs per cell: up to this many lights each is its own cluster.
/// A cell's build weighs this many clusters at most (× `crate::light_grid::LIGHT_GRID_MAX_CELLS`:
/// 1 M weights per frame); the clusters' buffer takes 48 bytes each.
pub const LIGHT_GRID_MAX_CLUSTERS: u32 = 256;

/// One cluster (48 bytes): lights `first .. first + count` of the light list.
///
/// | offset | field             |
/// |--------|-------------------|
/// | 0      | `lo`              |
/// | 12     | `first`           |
/// | 16     | `hi`              |
/// | 28     | `count`           |
/// | 32     | `near_power`      |
/// | 36     | `triangle_power`  |
/// | 40     | `distant_power`   |
/// | 44     | `environment`     |
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct LightCluster {
    /// Minimum corner of the point, spot and triangle lights' positions (a triangle's vertices).
    pub lo: [f32; 3],
    /// Index of the first light.
    pub first: u32,
    /// Maximum corner of those positions.
    pub hi: [f32; 3],
    /// Number of lights; 0 for the placeholder of an empty light list.
    pub count: u32,
    /// [`light_grid_power`] summed over the point and spot lights.
    pub near_power: f32,
    /// [`light_grid_power`] summed over the triangles (before the emissive multiplier).
    pub triangle_power: f32,
    /// [`light_grid_power`] summed over the directional lights.
    pub distant_power: f32,
    /// 1 when the cluster holds the environment light.
    pub environment: u32,
}

impl crate::layout::FloatLayout for LightCluster {
    const FLOAT_WORDS: &'static [u32] = &[0, 1, 2, 4, 5, 6, 8, 9, 10];
}

/// What a light gives at unit distance, the numerator of its grid weight: luminance of the
/// intensity (point, spot), of the irradiance (directional), of radiance × area × emitting sides
/// (triangle, before the emissive multiplier); 0 for the environment (weighed by the grid's
/// `environment_irradiance`) and for non-finite or negative values.
#[inline]
pub fn light_grid_power(light: &GpuLight) -> f32 {
    let mut p = luminance(Vec3::from_array(light.intensity));
    if light.kind == LIGHT_TRIANGLE {
        p *= light.area * light.emitting_sides();
    } else if light.kind == LIGHT_ENVIRONMENT {
        p = 0.0;
    }
    positive_or_zero(p)
}

/// Groups `lights` into at most `clusters.len()` clusters of consecutive lights (see the
/// [module](self)), writing each light's [`GpuLight::cluster`] and [`GpuLight::cluster_cdf`] and
/// the clusters; returns how many there are (0 for no lights or no room). Every light is its own
/// cluster while there are no more lights than room. Beyond that a cluster never mixes near
/// lights (point, spot, triangle), directional lights and the environment, unless the list
/// changes between them so often that the room would not hold the runs.
pub fn build_light_clusters(lights: &mut [GpuLight], clusters: &mut [LightCluster]) -> u32 {
    let n = lights.len();
    let capacity = clusters.len();
    if n == 0 || capacity == 0 {
        return 0;
    }
    let mut changes = 0;
    let mut i = 1;
    while i < n {
        if cluster_class(&lights[i]) != cluster_class(&lights[i - 1]) {
            changes += 1;
        }
        i += 1;
    }
    // Each change of class starts a cluster early: `Σ ceil(run / size) ≤ n / size + changes + 1`.
    let (size, by_class) = if n <= capacity {
        (1, true)
    } else if capacity > changes + 1 {
        (n.div_ceil(capacity - changes - 1), true)
    } else {
        (n.div_ceil(capacity), false)
    };
    let mut count = 0usize;
    i = 0;
    while i < n && count < capacity {
        let class = cluster_class(&lights[i]);
        let mut end = i + 1;
        while end < n && end - i < size && (!by_class || cluster_class(&lights[end]) == class) {
            end += 1;
        }
        clusters[count] = cluster_of(lights, i, end, count as u32);
        count += 1;
        i = end;
    }
    count as u32
}

/// Which lights may share a cluster: near lights (0), directional lights (1), the environment
/// (2).
#[inline]
fn cluster_class(light: &GpuLight) -> u32 {
    if light.kind == LIGHT_ENVIRONMENT {
        2
    } else if light.kind == LIGHT_DIRECTIONAL {
        1
    } else {
        0
    }
}

/// The cluster of lights `first .. end`, number `index`, writing its lights' cluster fields.
fn cluster_of(lights: &mut [GpuLight], first: usize, end: usize, index: u32) -> LightCluster {
    let mut c = LightCluster {
        lo: [0.0; 3],
        first: first as u32,
        hi: [0.0; 3],
        count: (end - first) as u32,
        ..LightCluster::default()
    };
    let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
    let mut total = 0.0;
    let mut j = first;
    while j < end {
        let l = &mut lights[j];
        let power = light_grid_power(l);
        total += power;
        // The running sum for now; divided by the total below.
        l.cluster = index;
        l.cluster_cdf = total;
        let p0 = Vec3::from_array(l.p0);
        if l.kind == LIGHT_TRIANGLE {
            c.triangle_power += power;
            lo = lo
                .min(p0)
                .min(Vec3::from_array(l.p1))
                .min(Vec3::from_array(l.p2));
            hi = hi
                .max(p0)
                .max(Vec3::from_array(l.p1))
                .max(Vec3::from_array(l.p2));
        } else if l.kind == LIGHT_DIRECTIONAL {
            c.distant_power += power;
        } else if l.kind == LIGHT_ENVIRONMENT {
            c.environment = 1;
        } else {
            c.near_power += power;
            lo = lo.min(p0);
            hi = hi.max(p0);
        }
        j += 1;
    }
    c.lo = lo.to_array();
    c.hi = hi.to_array();
    let count = (end - first) as f32;
    j = first;
    while j < end {
        let l = &mut lights[j];
        l.cluster_cdf = if j + 1 == end {
            1.0
        } else if total > 0.0 {
            l.cluster_cdf / total
        } else {
            // No power: uniform.
            (j + 1 - first) as f32 / count
        };
        j += 1;
    }
    c
}

/// Squared distance from `p` to the axis-aligned box `[lo, lo + size]` (0 inside).
#[inline]
fn box_distance_squared(p: Vec3, lo: Vec3, size: f32) -> f32 {
    let d = (lo - p).max(p - (lo + Vec3::splat(size))).max(Vec3::ZERO);
    d.length_squared()
}

/// The grid weight of `light` for the cell `[cell_min, cell_min + cell_size]³`: an estimate of
/// the irradiance (luminance) it gives inside the cell, never an exact bound.
///
/// * point and spot: `I / d²`, `d` the distance from the light to the cell, at least half a cell
///   (a light inside the cell does not get an infinite weight; spot cones are ignored);
/// * triangle: `L · sides · min(π, A / d²)`, `d` the distance from the triangle's bounding sphere
///   to the cell, at least half a cell (a near triangle cannot give more than `π L` per side);
/// * directional: its irradiance; environment: `environment_irradiance`.
///
/// Non-finite or negative results count as 0 where they are used.
#[inline]
pub fn light_grid_weight(
    light: &GpuLight,
    cell_min: Vec3,
    cell_size: f32,
    environment_irradiance: f32,
    emissive_multiplier: f32,
) -> f32 {
    let half = 0.5 * cell_size;
    let floor = half * half;
    let power = luminance(Vec3::from_array(light.intensity));
    if light.kind == LIGHT_POINT || light.kind == LIGHT_SPOT {
        let d2 = box_distance_squared(Vec3::from_array(light.p0), cell_min, cell_size);
        power / max(d2, floor)
    } else if light.kind == LIGHT_TRIANGLE {
        let (p0, p1, p2) = (
            Vec3::from_array(light.p0),
            Vec3::from_array(light.p1),
            Vec3::from_array(light.p2),
        );
        let centre = (p0 + p1 + p2) * (1.0 / 3.0);
        let radius = crate::math::sqrt(max(
            max(
                (p0 - centre).length_squared(),
                (p1 - centre).length_squared(),
            ),
            (p2 - centre).length_squared(),
        ));
        let d = max(
            crate::math::sqrt(box_distance_squared(centre, cell_min, cell_size)) - radius,
            0.0,
        );
        power
            * emissive_multiplier
            * light.emitting_sides()
            * min(PI, light.area / max(d * d, floor))
    } else if light.kind == LIGHT_DIRECTIONAL {
        power
    } else if light.kind == LIGHT_ENVIRONMENT {
        environment_irradiance
    } else {
        0.0
    }
}

/// The weight of `cluster` for the cell `[cell_min, cell_min + cell_size]³` (see the
/// [module](self)): a lone light's own grid weight ([`light_grid_weight`]);
/// else the near lights' power (triangles' × the emissive multiplier) over the squared distance
/// to the cluster's box (at least half a cell and `r² / count`, `r` the box's half diagonal),
/// plus the directional lights' power and the
/// environment's irradiance. 0 for an empty cluster or a non-finite weight.
#[inline]
pub fn cluster_weight(
    cluster: &LightCluster,
    lights: &[GpuLight],
    cell_min: Vec3,
    cell_size: f32,
    environment_irradiance: f32,
    emissive_multiplier: f32,
) -> f32 {
    let w = if cluster.count == 0 || cluster.first as usize >= lights.len() {
        0.0
    } else if cluster.count == 1 {
        light_grid_weight(
            &lights[cluster.first as usize],
            cell_min,
            cell_size,
            environment_irradiance,
            emissive_multiplier,
        )
    } else {
        let half = 0.5 * cell_size;
        let (lo, hi) = (Vec3::from_array(cluster.lo), Vec3::from_array(cluster.hi));
        let cell_max = cell_min + Vec3::splat(cell_size);
        let gap = (lo - cell_max).max(cell_min - hi).max(Vec3::ZERO);
        let near = cluster.near_power + cluster.triangle_power * emissive_multiplier;
        let mut w = cluster.distant_power;
        if near > 0.0 {
            // A cell inside or beside a wide cluster is near few of its lights: spread over
            // the box, they leave each an area of `radius² / count` around it.
            let spread = 0.25 * (hi - lo).length_squared() / cluster.count as f32;
            w += near / max(gap.length_squared(), max(half * half, spread));
        }
        if cluster.environment != 0 {
            w += environment_irradiance;
        }
        w
    };
    positive_or_zero(w)
}

/// The light of `cluster` whose interval of the cumulative probabilities holds `u ∈ [0, 1)`, and
/// its probability within the cluster ([`member_probability`]). A lone light is itself with
/// probability 1.
#[inline]
pub fn pick_in_cluster(cluster: &LightCluster, lights: &[GpuLight], u: f32) -> (u32, f32) {
    let n = lights.len() as u32;
    if n == 0 {
        return (0, 0.0);
    }
    let first = min_u32(cluster.first, n - 1);
    if cluster.count <= 1 {
        return (first, 1.0);
    }
    let last = min_u32(cluster.first + (cluster.count - 1), n - 1);
    // The first light whose cumulative value is above u.
    let (mut a, mut b) = (first, last);
    while a < b {
        let mid = a + (b - a) / 2;
        if u < lights[mid as usize].cluster_cdf {
            b = mid;
        } else {
            a = mid + 1;
        }
    }
    (a, member_probability(cluster, lights, a))
}

/// The probability with which [`pick_in_cluster`] draws light `index` of `cluster`: the width of
/// its interval of the cumulative probabilities.
#[inline]
pub fn member_probability(cluster: &LightCluster, lights: &[GpuLight], index: u32) -> f32 {
    if cluster.count <= 1 {
        return 1.0;
    }
    let i = index as usize;
    if i >= lights.len() {
        return 0.0;
    }
    let before = if index > cluster.first {
        lights[i - 1].cluster_cdf
    } else {
        0.0
    };
    max(lights[i].cluster_cdf - before, 0.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lights::EMIT_FRONT;
    use core::mem::{offset_of, size_of};

    #[test]
    fn layout() {
        use crate::layout::{FloatLayout, float_field_words};
        assert_eq!(size_of::<LightCluster>(), 48);
        assert_eq!(offset_of!(LightCluster, first), 12);
        assert_eq!(offset_of!(LightCluster, hi), 16);
        assert_eq!(offset_of!(LightCluster, count), 28);
        assert_eq!(offset_of!(LightCluster, near_power), 32);
        assert_eq!(offset_of!(LightCluster, triangle_power), 36);
        assert_eq!(offset_of!(LightCluster, distant_power), 40);
        assert_eq!(offset_of!(LightCluster, environment), 44);
        assert_eq!(
            LightCluster::FLOAT_WORDS,
            float_field_words(&[
                (offset_of!(LightCluster, lo), 3),
                (offset_of!(LightCluster, hi), 3),
                (offset_of!(LightCluster, near_power), 3)
            ])
        );
    }

    /// `points` point lights along x of intensity 1 + i, `triangles` triangles of area 0.5, a
    /// sun and the environment.
    fn lights(points: u32, triangles: u32) -> Vec<GpuLight> {
        let mut l: Vec<GpuLight> = (0..points)
            .map(|i| GpuLight::point(Vec3::new(i as f32, 0.0, 0.0), Vec3::splat(1.0 + i as f32)))
            .collect();
        l.extend((0..triangles).map(|i| {
            let o = Vec3::new(0.0, 5.0, i as f32);
            GpuLight::triangle(0, i, [o, o + Vec3::X, o + Vec3::Z], Vec3::ONE, EMIT_FRONT)
        }));
        l.push(GpuLight::directional(Vec3::NEG_Y, Vec3::ONE));
        l.push(GpuLight::ENVIRONMENT);
        l
    }

    /// Few lights: each its own cluster, picked with probability 1.
    #[test]
    fn few_lights_are_their_own_clusters() {
        let mut l = lights(5, 3);
        let mut c = [LightCluster::default(); 16];
        assert_eq!(build_light_clusters(&mut l, &mut c), 10);
        for (i, light) in l.iter().enumerate() {
            assert_eq!((light.cluster, light.cluster_cdf), (i as u32, 1.0));
            assert_eq!((c[i].first, c[i].count), (i as u32, 1));
            assert_eq!(pick_in_cluster(&c[i], &l, 0.7), (i as u32, 1.0));
        }
    }

    /// Many lights: at most the capacity, every light in the cluster its index names, the
    /// environment alone, each cluster's probabilities by power summing to 1, and the pick's
    /// frequencies following them.
    #[test]
    fn many_lights_share_clusters() {
        let mut l = lights(100, 300);
        let mut c = [LightCluster::default(); 16];
        let count = build_light_clusters(&mut l, &mut c) as usize;
        assert!(count <= 16 && count > 8, "{count}");
        let mut covered = 0;
        for (k, cluster) in c[..count].iter().enumerate() {
            assert_eq!(cluster.first as usize, covered);
            let members = &l[covered..][..cluster.count as usize];
            assert!(members.iter().all(|m| m.cluster == k as u32));
            let sum: f32 = (0..cluster.count)
                .map(|j| member_probability(cluster, &l, cluster.first + j))
                .sum();
            assert!((sum - 1.0).abs() < 1e-5, "{sum}");
            covered += cluster.count as usize;
        }
        assert_eq!(covered, l.len());
        assert_eq!(l.last().unwrap().kind, LIGHT_ENVIRONMENT);
        assert_eq!((c[count - 1].count, c[count - 1].environment), (1, 1));
        // The first cluster holds point lights of intensity 1, 2, …: picks follow them.
        let first = c[0];
        assert!(first.count > 2 && first.triangle_power == 0.0);
        let mut hits = [0u32; 64];
        let trials = 200_000;
        let mut rng = crate::random::Random::new(7, 0);
        for _ in 0..trials {
            let (i, p) = pick_in_cluster(&first, &l, rng.next_f32());
            assert_eq!(p, member_probability(&first, &l, i));
            hits[i as usize] += 1;
        }
        for (i, &hit) in hits.iter().enumerate().take(first.count as usize) {
            let expected = f64::from(member_probability(&first, &l, i as u32));
            let seen = f64::from(hit) / f64::from(trials);
            let sigma = (expected * (1.0 - expected) / f64::from(trials)).sqrt();
            assert!(
                (seen - expected).abs() < 4.0 * sigma,
                "{i}: {seen} {expected}"
            );
            assert!((expected - (1.0 + i as f64) / f64::from(first.near_power)).abs() < 1e-5);
        }
        // A far cell weighs a cluster less than a near one; the multiplier scales triangles.
        let tri = c[..count]
            .iter()
            .find(|c| c.triangle_power > 0.0 && c.near_power == 0.0);
        let tri = tri.unwrap();
        let near = cluster_weight(tri, &l, Vec3::new(0.0, 4.0, 10.0), 1.0, 0.0, 1.0);
        let far = cluster_weight(tri, &l, Vec3::new(0.0, 400.0, 10.0), 1.0, 0.0, 1.0);
        assert!(near > 10.0 * far && far > 0.0, "{near} {far}");
        assert_eq!(cluster_weight(tri, &l, Vec3::ZERO, 1.0, 0.0, 0.0), 0.0);
    }

    /// Room for two clusters (fewer than the classes): everything still lands in one, with
    /// probabilities
    /// summing to 1; nothing for no lights; black lights are drawn uniformly.
    #[test]
    fn degenerate_inputs() {
        let mut l = lights(10, 10);
        let mut c = [LightCluster::default(); 2];
        let count = build_light_clusters(&mut l, &mut c) as usize;
        assert_eq!(count, 2);
        assert_eq!(c[0].count + c[1].count, l.len() as u32);
        for cluster in &c {
            let sum: f32 = (0..cluster.count)
                .map(|j| member_probability(cluster, &l, cluster.first + j))
                .sum();
            assert!((sum - 1.0).abs() < 1e-5, "{sum}");
        }
        assert_eq!(build_light_clusters(&mut [], &mut c), 0);
        let mut black: Vec<GpuLight> = (0..40)
            .map(|_| GpuLight::point(Vec3::ZERO, Vec3::ZERO))
            .collect();
        let mut c = [LightCluster::default(); 8];
        let count = build_light_clusters(&mut black, &mut c) as usize;
        for cluster in &c[..count] {
            for j in 0..cluster.count {
                let p = member_probability(cluster, &black, cluster.first + j);
                assert!((p - 1.0 / cluster.count as f32).abs() < 1e-6, "{p}");
            }
            assert_eq!(
                cluster_weight(cluster, &black, Vec3::ZERO, 1.0, 0.0, 1.0),
                0.0
            );
        }
        let mut nan = lights(20, 0);
        nan[3].intensity = [f32::NAN; 3];
        let mut c = [LightCluster::default(); 8];
        build_light_clusters(&mut nan, &mut c);
        assert!(nan.iter().all(|l| l.cluster_cdf.is_finite()));
    }
}
