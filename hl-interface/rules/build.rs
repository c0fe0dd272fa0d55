//! Links Debian's static CLIPS 6.30 (`libclips-dev`: /usr/lib/libclips.a, headers in
//! /usr/include/clips; `CLIPS_LIB_DIR`, `CLIPS_INCLUDE_DIR` point elsewhere), with two changes
//! made to a copy in OUT_DIR:
//! * its `malloc`/`free` renamed to `robosim_clips_malloc`/`robosim_clips_free` (objcopy), so
//!   the rules' memory budget sees every CLIPS allocation (src/guard.c);
//! * src/guard.c, compiled against CLIPS's own headers, added to the archive.
use std::path::{Path, PathBuf};
use std::process::Command;

fn run(what: &str, cmd: &mut Command) {
    match cmd.status() {
        Ok(s) if s.success() => {}
        Ok(s) => panic!("{what} failed ({s}): {cmd:?}"),
        Err(e) => panic!("{what} could not start ({e}): {cmd:?}"),
    }
}

fn main() {
    let dir = std::env::var("CLIPS_LIB_DIR").unwrap_or_else(|_| "/usr/lib".into());
    let include =
        std::env::var("CLIPS_INCLUDE_DIR").unwrap_or_else(|_| "/usr/include/clips".into());
    let lib = Path::new(&dir).join("libclips.a");
    if !lib.is_file() || !Path::new(&include).join("clips.h").is_file() {
        panic!(
            "{} or {}/clips.h not found: install CLIPS with `apt-get install --no-install-recommends libclips-dev` (or set CLIPS_LIB_DIR and CLIPS_INCLUDE_DIR)",
            lib.display(),
            include
        );
    }
    println!("cargo:rerun-if-env-changed=CLIPS_LIB_DIR");
    println!("cargo:rerun-if-env-changed=CLIPS_INCLUDE_DIR");
    println!("cargo:rerun-if-changed=src/guard.c");
    let out = PathBuf::from(std::env::var("OUT_DIR").expect("cargo sets OUT_DIR"));
    let archive = out.join("libclips_robosim.a");
    run(
        "objcopy",
        Command::new(std::env::var("OBJCOPY").unwrap_or_else(|_| "objcopy".into()))
            .args([
                "--redefine-sym",
                "malloc=robosim_clips_malloc",
                "--redefine-sym",
                "free=robosim_clips_free",
            ])
            .arg(&lib)
            .arg(&archive),
    );
    let object = out.join("robosim_clips_guard.o");
    run(
        "compiling src/guard.c",
        Command::new(std::env::var("CC").unwrap_or_else(|_| "cc".into()))
            .args(["-c", "-O2", "-fPIC", "-std=gnu11", "-Wall", "-Wno-comment"])
            .arg(format!("-I{include}"))
            .arg("src/guard.c")
            .arg("-o")
            .arg(&object),
    );
    run(
        "ar",
        Command::new(std::env::var("AR").unwrap_or_else(|_| "ar".into()))
            .arg("rs")
            .arg(&archive)
            .arg(&object),
    );
    println!("cargo:rustc-link-search=native={}", out.display());
    println!("cargo:rustc-link-lib=static=clips_robosim");
    println!("cargo:rustc-link-lib=m");
}
