//! Finite elements for modal analysis: from a surface or tet mesh to sparse stiffness K and mass M.
//!
//! ```
//! use resound_fem::{primitive, discretize::{discretize_surface, VoxelParams}};
//! use resound_core::Material;
//! let bar = primitive::bar([0.3, 0.02, 0.01]);
//! let (fem, _report) = discretize_surface(&bar, &Material::preset("steel").unwrap(),
//!     &VoxelParams { resolution: 30, ..Default::default() }).unwrap();
//! assert_eq!(fem.n_dofs(), 3 * 31 * 3 * 2); // 30 x 2 x 1 voxels → 31 x 3 x 2 nodes
//! ```
//!
//! # Conventions
//! - Lengths in m, E in Pa, ρ in kg/m³; K in N/m, M in kg.
//! - DOF `3·node + c` is displacement component c (x, y, z) of a node.
//! - K and M are full symmetric CSC matrices (both triangles stored) with sorted row indices.
//!
//! # Method
//! A closed surface is voxelized on a grid fitted to its bounding box (so boxes are tiled
//! exactly), inside/outside by the winding number of each voxel centre (signed ray crossings).
//! Voxels are 8-node hexahedra with Wilson–Taylor incompatible modes ([`hex8i`]): unlike linear
//! tets or plain trilinear hexes they reproduce pure bending exactly, so thin parts need only one
//! or two elements through the thickness. Every voxel has the same element matrices, so
//! assembly copies one 24×24 block. Tet meshes given by the user are used as is with quadratic
//! 10-node tets ([`tet10`]), which do not lock either.
#![warn(missing_docs)]

pub mod assembly;
pub mod discretize;
pub mod hex8i;
pub mod primitive;
pub mod surface;
pub mod tet10;
pub mod voxel;

pub use discretize::{FemModel, TetMesh};
pub use surface::{MeshError, RepairReport, SurfaceMesh};
