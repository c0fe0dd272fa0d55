//! `robosim render SCENE|FILE.urdf …`: a URDF file is imported by the file interface into a
//! process-local model (robot, visuals and collision solids, as `robosim import urdf` does) and
//! drawn with [`cmd_render_store`]; anything else is a library scene or robot ([`cmd_render`]).
//!
//! Entry point: [`cmd_render_any`].

use crate::app::{RenderArgs, Result, cmd_render, cmd_render_store};
use std::path::Path;

/// `robosim render`: a `.urdf` file (any case) through the file interface, else the library.
pub fn cmd_render_any(args: &RenderArgs) -> Result<()> {
    let path = Path::new(&args.scene);
    let urdf = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("urdf"));
    if urdf {
        let store = robosim_file_io::urdf_session::urdf_store(path)?;
        cmd_render_store(args, store)
    } else {
        cmd_render(args)
    }
}
