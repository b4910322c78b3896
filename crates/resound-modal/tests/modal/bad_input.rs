//! Bad input gets an error naming the problem, never a panic.

use resound_core::Material;
use resound_fem::discretize::box_tets;
use resound_fem::{primitive, SurfaceMesh};
use resound_modal::{ModalBuilder, ModalParams};

fn run(mesh: &SurfaceMesh) -> String {
    let p = ModalParams {
        n_modes: Some(3),
        resolution: 10,
        ..Default::default()
    };
    ModalBuilder::surface(mesh, &Material::preset("steel").unwrap())
        .params(p.clone())
        .solve()
        .map(|s| (s.model, s.info))
        .map(|_| "ok".to_string())
        .unwrap_or_else(|e| e.to_string())
}

#[test]
fn bad_meshes_and_materials() {
    assert!(run(&SurfaceMesh::default()).contains("empty"));
    let mut nan = primitive::bar([0.1, 0.1, 0.1]);
    nan.vertices[3][0] = f64::NAN;
    assert!(run(&nan).contains("non-finite"));
    // Closed, manifold, but zero volume: a tetrahedron squashed into its base plane.
    let flat = SurfaceMesh {
        vertices: vec![
            [0.0, 0.0, 0.0],
            [0.1, 0.0, 0.0],
            [0.0, 0.1, 0.0],
            [0.03, 0.03, 0.0],
        ],
        triangles: vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]],
    };
    let e = run(&flat);
    assert!(e.contains("encloses no volume"), "{e}");
    let mut holed = primitive::sphere(0.05, 24);
    holed.triangles.truncate(holed.triangles.len() - 5);
    let e = run(&holed);
    assert!(
        e.contains("boundary loop") && e.contains("not closed"),
        "{e}"
    );
    // A thin shell at a coarse resolution voxelizes to nothing.
    let p = ModalParams {
        n_modes: Some(3),
        resolution: 4,
        ..Default::default()
    };
    let e = ModalBuilder::surface(
        &primitive::bowl(0.1, 0.001, 0.1, 48),
        &Material::preset("steel").unwrap(),
    )
    .params(p.clone())
    .solve()
    .map(|s| (s.model, s.info))
    .unwrap_err()
    .to_string();
    assert!(e.contains("no inside voxel"), "{e}");
    // Absurd materials.
    assert!(Material::parse("1e30,0.3,7850").is_err());
    assert!(Material::parse("200e9,0.7,7850").is_err());
    let bad = Material {
        name: "x".into(),
        youngs_modulus: -5.0,
        poisson_ratio: 0.3,
        density: 1.0,
    };
    let p = ModalParams {
        n_modes: Some(3),
        resolution: 10,
        ..Default::default()
    };
    assert!(
        ModalBuilder::surface(&primitive::bar([0.1, 0.1, 0.1]), &bad)
            .params(p.clone())
            .solve()
            .map(|s| (s.model, s.info))
            .is_err()
    );
    // Absurd parameters.
    let p = ModalParams {
        n_modes: Some(0),
        ..Default::default()
    };
    assert!(ModalBuilder::surface(
        &primitive::bar([0.1, 0.1, 0.1]),
        &Material::preset("steel").unwrap()
    )
    .params(p.clone())
    .solve()
    .map(|s| (s.model, s.info))
    .is_err());
    let p = ModalParams {
        n_modes: Some(1_000_000),
        ..Default::default()
    };
    let e = ModalBuilder::surface(
        &primitive::bar([0.1, 0.1, 0.1]),
        &Material::preset("steel").unwrap(),
    )
    .params(p.clone())
    .solve()
    .map(|s| (s.model, s.info))
    .unwrap_err()
    .to_string();
    assert!(e.contains("more than the supported"), "{e}");
    let p = ModalParams {
        max_freq_hz: Some(-1.0),
        ..Default::default()
    };
    assert!(ModalBuilder::surface(
        &primitive::bar([0.1, 0.1, 0.1]),
        &Material::preset("steel").unwrap()
    )
    .params(p.clone())
    .solve()
    .map(|s| (s.model, s.info))
    .is_err());
}

#[test]
fn inverted_tets_are_reported() {
    let mut t = box_tets([0.1, 0.02, 0.02], [4, 1, 1]);
    t.tets[5].swap(1, 2);
    let p = ModalParams {
        n_modes: Some(3),
        ..Default::default()
    };
    let e = ModalBuilder::tets(&t, &Material::preset("steel").unwrap())
        .params(p.clone())
        .solve()
        .map(|s| (s.model, s.info, s.fem))
        .unwrap_err()
        .to_string();
    assert!(e.contains("tetrahedron 5 is inverted"), "{e}");
}
