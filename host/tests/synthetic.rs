//! `gi generate`'s scenes: they load with the loader, with the requested world triangle count
//! (instanced: far fewer unique triangles), inside their room, lit and framed; bad parameters are
//! refused with a message naming them. CPU only.

use gi_host::Error;
use gi_host::scene::Scene;
use gi_host::scene::synthetic::{self, SyntheticParams};

fn check(triangles: u64, unique_meshes: u32) {
    let dir = std::env::temp_dir().join(format!("gi-synthetic-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(format!("synthetic-{triangles}.glb"));
    let params = SyntheticParams {
        triangles,
        unique_meshes,
        seed: 7,
    };
    let made = synthetic::write(&params, &path).unwrap();
    let (scene, warnings) = Scene::load(&path).unwrap();
    std::fs::remove_file(&path).unwrap();
    assert!(warnings.is_empty(), "{warnings:#?}");

    // The world count reaches the request and overshoots by less than the smallest mesh.
    let world = scene.triangle_count() as u64;
    assert_eq!(world, made.world_triangles);
    let smallest = scene
        .meshes
        .iter()
        .map(|m| m.triangles.len())
        .min()
        .unwrap() as u64;
    let objects: Vec<_> = scene.meshes.iter().skip(2).collect();
    assert_eq!(objects.len(), unique_meshes as usize);
    let smallest_object = objects.iter().map(|m| m.triangles.len()).min().unwrap() as u64;
    assert!(
        world >= triangles && world < triangles + smallest_object,
        "{world} triangles for {triangles} (smallest mesh {smallest})"
    );
    let unique: u64 = scene.meshes.iter().map(|m| m.triangles.len() as u64).sum();
    assert_eq!(unique, made.unique_triangles);
    assert_eq!(scene.instances.len() as u64, made.instances + 2);
    // Instanced: each unique mesh is placed several times on average.
    assert!(
        unique * 4 < world,
        "{unique} unique triangles for {world} in the world"
    );

    // Everything lies inside the room, which holds it tightly.
    let half = made.room_half_width;
    let eps = 1e-3;
    assert!((scene.bounds.min.x + half).abs() < eps && (scene.bounds.max.x - half).abs() < eps);
    assert!((scene.bounds.min.z + half).abs() < eps && (scene.bounds.max.z - half).abs() < eps);
    assert!(scene.bounds.min.y.abs() < eps && (scene.bounds.max.y - 3.0).abs() < eps);
    for instance in scene.instances.iter().skip(2) {
        let p = instance.transform.w_axis.truncate();
        assert!(
            p.x.abs() < half && p.z.abs() < half && p.y > 0.0 && p.y < 0.5,
            "{p}"
        );
    }
    // Lit by the lamp's two triangles, and framed by a camera inside the room.
    assert_eq!(scene.emissive_triangles.len(), 2);
    assert_eq!(scene.cameras.len(), 1);
    let eye = scene.cameras[0].position();
    assert!(eye.x.abs() < half && eye.z.abs() < half && eye.y > 0.0 && eye.y < 3.0);
    let to_centre = (glam::Vec3::new(0.0, 0.5, 0.0) - eye).normalize();
    assert!(scene.cameras[0].forward().dot(to_centre) > 0.999);
}

#[test]
fn ten_thousand_triangles() {
    check(10_000, 4);
}

#[test]
fn a_million_triangles() {
    check(1_000_000, 5);
}

#[test]
fn the_same_parameters_give_the_same_file() {
    let params = SyntheticParams {
        triangles: 20_000,
        unique_meshes: 3,
        seed: 3,
    };
    let a = synthetic::generate(&params).unwrap();
    assert_eq!(a, synthetic::generate(&params).unwrap());
    let other = synthetic::generate(&SyntheticParams { seed: 4, ..params }).unwrap();
    assert_ne!(a.glb, other.glb);
}

#[test]
fn bad_parameters_are_refused_by_name() {
    let refused = |params: SyntheticParams, name: &str| match synthetic::generate(&params) {
        Err(e @ Error::InvalidArgument { .. }) => {
            let message = e.to_string();
            assert!(message.contains(name), "{message}");
        }
        other => panic!("{params:?}: {other:?}"),
    };
    let ok = SyntheticParams::default();
    refused(SyntheticParams { triangles: 0, ..ok }, "triangles");
    refused(
        SyntheticParams {
            triangles: 999,
            ..ok
        },
        "triangles",
    );
    refused(
        SyntheticParams {
            triangles: 1_000_000_000_000_000,
            ..ok
        },
        "triangles",
    );
    refused(
        SyntheticParams {
            unique_meshes: 0,
            ..ok
        },
        "unique-meshes",
    );
    refused(
        SyntheticParams {
            unique_meshes: 65,
            ..ok
        },
        "unique-meshes",
    );
}

#[test]
fn counts_parse_with_decimal_suffixes() {
    assert_eq!(synthetic::parse_count("10000"), Ok(10_000));
    assert_eq!(synthetic::parse_count("10k"), Ok(10_000));
    assert_eq!(synthetic::parse_count("1.5M"), Ok(1_500_000));
    assert_eq!(synthetic::parse_count("2G"), Ok(2_000_000_000));
    for bad in ["", "ten", "-5", "1e400", "M", "1.5.2k", "nan"] {
        let error = synthetic::parse_count(bad).unwrap_err();
        assert!(error.contains("is not a count"), "{bad}: {error}");
    }
}
