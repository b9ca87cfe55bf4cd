//! The probe reuse test of GI-1.0 (reprojection, neighbour gather, LRU match, filtering): a probe
//! may stand for a surface point when the point lies within one screen-probe cell size of the
//! probe's plane and the normals agree (`dot > 0.95`).

use glam::Vec3;

use super::{GiFrameParams, REUSE_MIN_NORMAL_DOT};

/// The reuse score of a probe at `probe_position` with unit normal `probe_normal` for the surface
/// point `position` with unit normal `normal`: the point's distance to the probe's plane in units
/// of the cell size at the point's distance from the eye (lower is better), or `None` when the
/// probe may not stand for the point. NaN inputs give `None`.
#[inline]
pub fn reuse_score(
    params: &GiFrameParams,
    probe_position: Vec3,
    probe_normal: Vec3,
    position: Vec3,
    normal: Vec3,
) -> Option<f32> {
    let cell = params.probe_cell_size((position - Vec3::from_array(params.eye)).length());
    let plane = (probe_position - position).dot(normal).abs();
    let score = plane / cell;
    if normal.dot(probe_normal) > REUSE_MIN_NORMAL_DOT && score < 1.0 && cell > 0.0 {
        Some(score)
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reuse_needs_the_plane_and_the_normal() {
        let params = GiFrameParams {
            probe_cell_const: 0.01,
            ..Default::default()
        };
        // 10 units away: cell size 0.1.
        let p = Vec3::new(0.0, 0.0, 10.0);
        let n = Vec3::Z;
        assert_eq!(reuse_score(&params, p, n, p, n), Some(0.0));
        let s = reuse_score(&params, p + Vec3::new(3.0, 0.0, 0.05), n, p, n).unwrap();
        assert!((s - 0.5).abs() < 1e-4, "{s}");
        assert_eq!(reuse_score(&params, p + Vec3::Z * 0.2, n, p, n), None);
        let tilted = Vec3::new(0.4, 0.0, 1.0).normalize();
        assert_eq!(reuse_score(&params, p, tilted, p, n), None);
        assert_eq!(reuse_score(&params, p, n, Vec3::NAN, n), None);
    }
}
