//! Every mesh reader (OBJ, STL, PLY, gmsh MSH, TetGen, MEDIT); the first byte picks the
//! format. A mesh that loads has finite coordinates and in-range indices.
#![no_main]
use libfuzzer_sys::fuzz_target;
use resound_io::mesh::LoadedMesh;

#[path = "common.rs"]
mod common;

fuzz_target!(|data: &[u8]| {
    let Some((&pick, rest)) = data.split_first() else {
        return;
    };
    let ext = ["obj", "stl", "ply", "msh", "node", "mesh"][usize::from(pick) % 6];
    let path = common::scratch(ext, rest);
    match resound_io::mesh::load_mesh(&path, 1.0) {
        Ok(LoadedMesh::Surface(s)) => {
            let n = s.vertices.len() as u32;
            assert!(s.vertices.iter().flatten().all(|c| c.is_finite()));
            assert!(s.triangles.iter().flatten().all(|&i| i < n));
        }
        Ok(LoadedMesh::Tets(t)) => {
            let n = t.nodes.len() as u32;
            assert!(t.nodes.iter().flatten().all(|c| c.is_finite()));
            assert!(t.tets.iter().flatten().all(|&i| i < n));
        }
        Err(_) => {}
    }
});
