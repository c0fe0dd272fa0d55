//! The standard library, shipped inside the crate (the files in `library-space/stdlib/`).

/// (name, text) of every standard-library file; `include "std"` loads them all,
/// `include "std/puma560.rsl"` one.
pub const FILES: &[(&str, &str)] = &[
    ("std/materials.rsl", include_str!("../stdlib/materials.rsl")),
    ("std/puma560.rsl", include_str!("../stdlib/puma560.rsl")),
    ("std/stanford.rsl", include_str!("../stdlib/stanford.rsl")),
    ("std/panda.rsl", include_str!("../stdlib/panda.rsl")),
    ("std/surgical.rsl", include_str!("../stdlib/surgical.rsl")),
    ("std/welding.rsl", include_str!("../stdlib/welding.rsl")),
    ("std/station.rsl", include_str!("../stdlib/station.rsl")),
];
