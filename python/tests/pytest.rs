//! Runs the Python package's pytest suite (python/tests/test_*.py) against real sessions, as
//! part of `cargo test --workspace`: the extension module this crate builds
//! (`target/<profile>/lib_robosim.so`) and the package sources are put in a temp directory as
//! the package `robosim`, and pytest runs with it first on the path. The sessions use the
//! `robosim` binary of the same target directory (`ROBOSIM_BIN`).
//!
//! Needs python3 with numpy and pytest (`pip install numpy pytest`; .ci/run installs them).
//! Without python3 the test says so loudly and passes — unless the environment variable `CI` is
//! set, when it fails (CI must run the suite); with python3 but without numpy or pytest it
//! fails, naming what to install.

use std::path::{Path, PathBuf};
use std::process::Command;

/// target/<profile>: this test binary lives in target/<profile>/deps/.
fn profile_dir() -> PathBuf {
    let exe = std::env::current_exe().expect("test executable path");
    exe.parent()
        .and_then(Path::parent)
        .expect("target/<profile>/deps/<test>")
        .to_owned()
}

#[test]
fn pytest_suite_passes_against_real_sessions() {
    let python = std::env::var("PYTHON").unwrap_or_else(|_| "python3".into());
    if Command::new(&python).arg("--version").output().is_err() {
        assert!(
            std::env::var_os("CI").is_none(),
            "CI is set but there is no {python} on this machine: the Python package's pytest suite cannot run"
        );
        eprintln!(
            "\n*** SKIPPED: no {python} on this machine: the Python package's pytest suite did NOT run ***\n"
        );
        return;
    }
    let probe = Command::new(&python)
        .args(["-c", "import numpy, pytest"])
        .output()
        .expect("run python");
    assert!(
        probe.status.success(),
        "{python} lacks numpy or pytest (`pip install numpy pytest`): {}",
        String::from_utf8_lossy(&probe.stderr)
    );
    let dir = profile_dir();
    // `cargo build` puts the extension in target/<profile>/; when `cargo test` builds it as this
    // test's dependency it stays in target/<profile>/deps/. Take the newer of the two.
    let lib = ["lib_robosim.so", "deps/lib_robosim.so"]
        .iter()
        .map(|p| dir.join(p))
        .filter(|p| p.is_file())
        .max_by_key(|p| p.metadata().and_then(|m| m.modified()).ok())
        .unwrap_or_else(|| dir.join("lib_robosim.so"));
    let bin = dir.join("robosim");
    assert!(
        lib.is_file(),
        "{} is missing: build the workspace",
        lib.display()
    );
    assert!(
        bin.is_file(),
        "{} is missing: `cargo build --workspace` (the suite starts real sessions)",
        bin.display()
    );
    let crate_dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let site = tempfile::tempdir().expect("temp dir");
    let pkg = site.path().join("robosim");
    std::fs::create_dir(&pkg).expect("package dir");
    for e in std::fs::read_dir(crate_dir.join("robosim")).expect("python/robosim") {
        let p = e.expect("entry").path();
        if p.is_file() {
            std::fs::copy(&p, pkg.join(p.file_name().expect("name"))).expect("copy source");
        }
    }
    std::fs::copy(&lib, pkg.join("_robosim.abi3.so")).expect("copy the extension");
    let out = Command::new(&python)
        .args(["-m", "pytest", "-q", "-p", "no:cacheprovider"])
        .arg(crate_dir.join("tests"))
        .env("PYTHONPATH", site.path())
        .env("ROBOSIM_BIN", &bin)
        .env("IOX2_LOG_LEVEL", "Error")
        .current_dir(site.path())
        .output()
        .expect("run pytest");
    let stdout = String::from_utf8_lossy(&out.stdout);
    println!("{stdout}");
    assert!(
        out.status.success(),
        "pytest failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
}
