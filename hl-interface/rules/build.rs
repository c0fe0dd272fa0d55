//! Links Debian's static CLIPS 6.30 (`libclips-dev`: /usr/lib/libclips.a, headers in
//! /usr/include/clips; `CLIPS_LIB_DIR`, `CLIPS_INCLUDE_DIR` point elsewhere) and sets
//! `cfg(clips)`. Without them the engine is left out, loudly: one `cargo:warning` here, and
//! `robosim rules` says what to install (cargo alone builds and runs everything else;
//! tools/no-clips-check.sh shows it). When found, two changes are made to a copy in OUT_DIR:
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

/// What `robosim rules` and the build say when CLIPS is missing (the crate's `NOT_BUILT` too).
const INSTALL: &str = "install it with `sudo apt-get install --no-install-recommends libclips-dev` and rebuild (`cargo clean -p robosim-rules`, then build again)";

fn main() {
    println!("cargo::rustc-check-cfg=cfg(clips)");
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-env-changed=CLIPS_LIB_DIR");
    println!("cargo:rerun-if-env-changed=CLIPS_INCLUDE_DIR");
    let dir = std::env::var("CLIPS_LIB_DIR").unwrap_or_else(|_| "/usr/lib".into());
    let include =
        std::env::var("CLIPS_INCLUDE_DIR").unwrap_or_else(|_| "/usr/include/clips".into());
    let lib = Path::new(&dir).join("libclips.a");
    let header = Path::new(&include).join("clips.h");
    if !lib.is_file() || !header.is_file() {
        // Left out loudly: everything else builds and runs; `robosim rules` says what is
        // missing and how to get it, and the tests that need CLIPS say they were skipped.
        let missing = if lib.is_file() { &header } else { &lib };
        println!(
            "cargo:warning=robosim-rules: {} not found, so the CLIPS rule engine (`robosim rules`) is left out of this build; {INSTALL}",
            missing.display()
        );
        return;
    }
    println!("cargo:rustc-cfg=clips");
    println!("cargo:rerun-if-changed={}", lib.display());
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
