//! URDF reading (issue #14), split out of the file interface (`robosim-file-io`) so that the
//! Library Space can declare a robot `from_urdf "file"` without depending on file-io (which
//! depends on the Library Space). Nothing here knows sessions, scenes or the library:
//! plain files in, plain data (`robosim_kinematics::Robot`, collision solids) out.
//!
//! * [`urdf_import`] — a URDF read as a chain ([`urdf_import::import_urdf`]) or as the whole
//!   tree ([`urdf_import::import_urdf_tree`]); every error names the file, line and element.
//! * [`urdf_geometry`] — its visual and collision geometry (meshes loaded lazily,
//!   [`urdf_geometry::MeshRef::load`]); `robosim_model::Model::from_imported` converts it into
//!   the robot model's geometry, whose collision solids `robosim_model::geometry::link_solids`
//!   builds.
//! * [`package`] — `package://` names resolved against `ROS_PACKAGE_PATH` and the URDF's
//!   ancestors.
//! * [`dae`] — Collada visual meshes; [`stl`], [`obj`] — the STL and OBJ mesh readers.
//! * [`mjcf`] — MuJoCo's MJCF read into the same [`ImportedRobot`] (issue 36 item 5;
//!   [`mjcf::import_mjcf_tree`], [`mjcf::import_mjcf`]); its frame and geom arithmetic in
//!   [`mjcf_frame`].
//!
//! `robosim-file-io` re-exports these modules under their old paths
//! (`robosim_file_io::urdf_import`, …).

#![forbid(unsafe_code)]

pub mod dae;
pub mod mjcf;
pub mod mjcf_frame;
pub mod obj;
pub mod package;
pub mod stl;
pub mod urdf_geometry;
pub mod urdf_import;
mod urdf_xml;

pub use mjcf::{MjcfError, MjcfErrorKind, import_mjcf, import_mjcf_tree};
pub use urdf_import::{
    ImportedRobot, UrdfError, UrdfErrorKind, UrdfRobot, import_urdf, import_urdf_tree,
};
