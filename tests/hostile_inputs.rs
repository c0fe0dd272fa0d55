//! The hostile-input corpus (issue 34): every row of `testdata/hostile/MANIFEST.tsv` — a file,
//! the reader it is fed to, the error kind it must give — run through the public API and, where
//! that is cheap, through the `robosim` binary. A wrong kind, a message that does not name the
//! file, a panic, an abort, a stack overflow or a hang fails the test, which lists every failing
//! row at the end (it does not stop at the first).
//!
//! Each row runs in a child process (this test binary again, test `hostile_case_child`, with the
//! row in `ROBOSIM_HOSTILE_CASE`) under a 2 GiB address-space limit and a timeout: a stack
//! overflow or an out-of-memory abort kills the child, not the test, and is reported as what it
//! is. A child blocked on a FIFO is unblocked by the test (it opens the FIFO's other end after
//! [`HANG_S`] s) and reported as a hang.
//!
//! Files too big or too special to keep in the repository are made by the test in a scratch
//! copy of `testdata/hostile/`: `@nested20000.urdf` / `.dae` (XML nested 20,000 deep), `@fifo.EXT`
//! (a FIFO), `@zero.EXT` (a symlink to /dev/zero), `@dir.EXT` (a directory); `A+@fifo:B` copies A
//! and makes B beside it.

use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Seconds a reader may take on one hostile file before it is a hang.
const HANG_S: u64 = 10;
/// Address space of a child (bytes): an unbounded allocation fails here instead of swapping.
const CHILD_AS: u64 = 2 << 30;
const CASE_ENV: &str = "ROBOSIM_HOSTILE_CASE";

struct Row {
    line: usize,
    file: String,
    reader: String,
    expect: Vec<String>,
    note: String,
}

fn manifest_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("testdata/hostile")
}

fn rows() -> Vec<Row> {
    let path = manifest_dir().join("MANIFEST.tsv");
    let text = std::fs::read_to_string(&path).expect("testdata/hostile/MANIFEST.tsv");
    let mut out = Vec::new();
    for (k, line) in text.lines().enumerate() {
        if line.trim().is_empty() || line.starts_with('#') {
            continue;
        }
        let f: Vec<&str> = line.split('\t').collect();
        assert!(
            f.len() >= 3,
            "MANIFEST.tsv:{}: file, reader, expect, note (tab-separated)",
            k + 1
        );
        out.push(Row {
            line: k + 1,
            file: f[0].to_string(),
            reader: f[1].to_string(),
            expect: f[2].split('|').map(str::to_string).collect(),
            note: f.get(3).copied().unwrap_or("").to_string(),
        });
    }
    out
}

/// Copies testdata/hostile/ into `dir` (files only, one level of folders).
fn copy_corpus(dir: &Path) {
    for e in std::fs::read_dir(manifest_dir()).expect("testdata/hostile") {
        let e = e.expect("entry");
        let to = dir.join(e.file_name());
        if e.file_type().expect("type").is_dir() {
            std::fs::create_dir_all(&to).expect("mkdir");
            for f in std::fs::read_dir(e.path()).expect("folder") {
                let f = f.expect("entry");
                std::fs::copy(f.path(), to.join(f.file_name())).expect("copy");
            }
        }
    }
}

fn mkfifo(path: &Path) {
    let c = std::ffi::CString::new(path.as_os_str().as_encoded_bytes()).expect("path");
    // SAFETY: a NUL-terminated path and a mode; mkfifo reads nothing else.
    let r = unsafe { libc::mkfifo(c.as_ptr(), 0o600) };
    assert_eq!(r, 0, "mkfifo {}", path.display());
}

/// Makes `@KIND.EXT` (or `@KIND:NAME`) at `at`; returns its path.
fn generate(spec: &str, at: &Path) -> PathBuf {
    let spec = spec.trim_start_matches('@');
    let (kind, name) = match spec.split_once(':') {
        Some((k, n)) => (k.to_string(), n.to_string()),
        None => {
            let (k, ext) = spec.split_once('.').expect("@KIND.EXT");
            (k.to_string(), format!("{k}.{ext}"))
        }
    };
    let path = at.join(&name);
    match kind.as_str() {
        "fifo" => mkfifo(&path),
        "zero" => std::os::unix::fs::symlink("/dev/zero", &path).expect("symlink"),
        "dir" => std::fs::create_dir_all(&path).expect("mkdir"),
        "nested20000" => {
            let n = 20_000;
            let text = if name.ends_with(".urdf") {
                format!(
                    "<robot name=\"deep\">{}{}</robot>\n",
                    "<link name=\"a\">".repeat(n),
                    "</link>".repeat(n)
                )
            } else {
                format!(
                    "<COLLADA><library_visual_scenes><visual_scene id=\"s\">{}{}</visual_scene></library_visual_scenes></COLLADA>\n",
                    "<node>".repeat(n),
                    "</node>".repeat(n)
                )
            };
            std::fs::write(&path, text).expect("write");
        }
        other => panic!("unknown generated file @{other}"),
    }
    path
}

/// The file a row reads, made in `dir` (a scratch copy of the corpus).
fn materialise(row: &Row, dir: &Path) -> PathBuf {
    let mut parts = row.file.split('+');
    let first = parts.next().unwrap_or("");
    let path = if first.starts_with('@') {
        generate(first, dir)
    } else {
        dir.join(first)
    };
    for extra in parts {
        let at = path.parent().unwrap_or(dir);
        generate(extra, at);
    }
    path
}

/// The outcome of one reader on one file.
#[derive(Debug)]
enum Outcome {
    /// Kind and message (kind `ok`: accepted; the message then says what was read).
    Done {
        kind: String,
        message: String,
    },
    Crashed(String),
    Hung,
}

/// The variant path of a `Debug` string: `Mesh(Read("…"))` → `Mesh/Read`,
/// `NegativeMass(-2.0)` → `NegativeMass`, `Model { problem: Cycle { … } }` → `Model`.
fn variant_path(debug: &str) -> String {
    let mut out = Vec::new();
    let mut rest = debug;
    loop {
        let ident: String = rest
            .chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
            .collect();
        if ident.is_empty() || !ident.starts_with(|c: char| c.is_ascii_uppercase()) {
            break;
        }
        out.push(ident.clone());
        rest = &rest[ident.len()..];
        match rest.strip_prefix('(') {
            Some(r) => rest = r,
            None => break,
        }
    }
    out.join("/")
}

fn file_error_kind(e: &robosim_file_io::FileError) -> String {
    use robosim_file_io::FileError as F;
    match e {
        F::Model { problem, .. } => format!("File/Model/{}", variant_path(&format!("{problem:?}"))),
        other => format!("File/{}", variant_path(&format!("{other:?}"))),
    }
}

/// Runs `reader` on `path` in this process; what `hostile_case_child` prints.
fn read_with(reader: &str, path: &Path) -> (String, String) {
    use robosim_file_io::urdf_import::{import_urdf, import_urdf_tree};
    let urdf_kind = |e: &robosim_file_io::urdf_import::UrdfError| {
        (
            format!("Urdf/{}", variant_path(&format!("{:?}", e.kind))),
            e.to_string(),
        )
    };
    match reader {
        "urdf" => match import_urdf(path, None) {
            Ok(r) => ("ok".into(), format!("{} joints", r.robot.dof())),
            Err(e) => urdf_kind(&e),
        },
        // The import, then the robot model's collision solids (meshes read now): a mesh's
        // error is the reader's, named as the import's are.
        "urdf-solids" => match import_urdf_tree(path) {
            Ok(r) => match robosim_model::Model::from(&r).collision_solids() {
                Ok(_) => (
                    "ok".into(),
                    format!("{} joints and their solids", r.robot.dof()),
                ),
                Err(e) => match e.mesh() {
                    Some(m) => urdf_kind(m),
                    None => (
                        format!("Geometry/{}", variant_path(&format!("{e:?}"))),
                        e.to_string(),
                    ),
                },
            },
            Err(e) => urdf_kind(&e),
        },
        "mesh" => match robosim_file_io::import::read_mesh(path, 1.0)
            .and_then(|t| robosim_file_io::import::mesh_geometry(&t, false, path).map(|g| (t, g)))
        {
            Ok((tris, g)) => {
                let area: f64 = tris.iter().map(|t| triangle_area(t)).sum();
                (
                    format!("ok:area={}", (area * 1e9).round() / 1e9),
                    format!(
                        "{} triangles, {} polygons",
                        tris.len(),
                        g.geometry.polygons.len()
                    ),
                )
            }
            Err(e) => (file_error_kind(&e), e.to_string()),
        },
        "dae" => match std::fs::read(path) {
            Err(e) => ("Io".into(), format!("{}: {e}", path.display())),
            Ok(bytes) => match robosim_file_io::dae::read_dae(&bytes, path) {
                Ok(parts) => ("ok".into(), format!("{} parts", parts.len())),
                Err(e) => ("Dae".into(), e.to_string()),
            },
        },
        "model" => match robosim_file_io::format::read(path) {
            Err(e) => (file_error_kind(&e), e.to_string()),
            Ok(m) => match m.to_transaction(&[]) {
                Err(p) => (
                    format!("File/Model/{}", variant_path(&format!("{p:?}"))),
                    format!("{}: {p}", path.display()),
                ),
                Ok(plan) => match robosim_instance_space::Store::new().apply(&plan.tx) {
                    Ok(_) => ("ok".into(), format!("{} objects", m.objects.len())),
                    // What `robosim load` says: the file and the object the keeper refused.
                    Err(e) => (
                        format!("Tx/{}", variant_path(&format!("{e:?}"))),
                        format!("{}: {e}", path.display()),
                    ),
                },
            },
        },
        "linkfile" => {
            use robosim_file_io::linkfile::LinkFile;
            let kind = |e: &robosim_file_io::linkfile::LinkFileError| {
                (
                    format!("LinkFile/{}", variant_path(&format!("{e:?}"))),
                    e.to_string(),
                )
            };
            match LinkFile::read(path).and_then(|f| f.solids(path).map(|s| (f, s))) {
                Ok((f, s)) => (
                    "ok".into(),
                    format!("{} vectors, {} solids", f.vectors.len(), s.len()),
                ),
                Err(e) => kind(&e),
            }
        }
        "program" => {
            let out = tempfile::tempdir().expect("tempdir");
            match robosim_editor::cli::lang_run(path, out.path()).map_err(|e| e.to_string()) {
                Err(m) => {
                    let p = path.display().to_string();
                    let located = m
                        .strip_prefix(&format!("{p}:"))
                        .and_then(|r| r.split_once(':'))
                        .is_some_and(|(line, r)| {
                            line.parse::<usize>().is_ok()
                                && r.split_once(':')
                                    .is_some_and(|(c, _)| c.parse::<usize>().is_ok())
                        });
                    let kind = if located {
                        "Lang"
                    } else if m.contains("stores no link") {
                        "NoLink"
                    } else {
                        "Io"
                    };
                    (kind.into(), m)
                }
                // `lang load` must read what `lang run` wrote.
                Ok(_) => {
                    for f in std::fs::read_dir(out.path()).expect("out") {
                        let f = f.expect("entry").path();
                        if let Err(e) = robosim_file_io::linkfile::LinkFile::read(&f) {
                            return (
                                format!("LinkFile/{}", variant_path(&format!("{e:?}"))),
                                format!(
                                    "{} (written by lang run from {}): {e}",
                                    f.display(),
                                    path.display()
                                ),
                            );
                        }
                    }
                    ("ok".into(), "ran; its link files read back".into())
                }
            }
        }
        other => panic!("unknown reader {other:?}"),
    }
}

fn triangle_area(t: &[[f64; 3]; 3]) -> f64 {
    let u = [t[1][0] - t[0][0], t[1][1] - t[0][1], t[1][2] - t[0][2]];
    let v = [t[2][0] - t[0][0], t[2][1] - t[0][1], t[2][2] - t[0][2]];
    let c = [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ];
    0.5 * (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt()
}

/// One row in a child process (see the module docs). Does nothing without `ROBOSIM_HOSTILE_CASE`.
#[test]
fn hostile_case_child() {
    let Ok(spec) = std::env::var(CASE_ENV) else {
        return;
    };
    let (reader, path) = spec.split_once('\t').expect("READER\\tPATH");
    let lim = libc::rlimit {
        rlim_cur: CHILD_AS,
        rlim_max: CHILD_AS,
    };
    // SAFETY: setrlimit reads the struct; it only lowers this process's own limit.
    unsafe { libc::setrlimit(libc::RLIMIT_AS, &lim) };
    let (kind, message) = read_with(reader, Path::new(path));
    println!("HOSTILE-KIND: {kind}");
    println!("HOSTILE-MESSAGE: {}", message.replace('\n', " / "));
}

/// Runs `cmd` (stdin from `input`), killing it after [`HANG_S`] s; while it runs, FIFOs among
/// `fifos` are opened for writing after `HANG_S / 2` s, so a reader blocked in `open` sees an
/// empty FIFO instead of hanging forever. (exit status or None when killed, stdout, stderr).
fn run_bounded(
    mut cmd: Command,
    input: Option<&str>,
    fifos: &[PathBuf],
) -> (Option<std::process::ExitStatus>, String, String, bool) {
    cmd.stdin(if input.is_some() {
        Stdio::piped()
    } else {
        Stdio::null()
    })
    .stdout(Stdio::piped())
    .stderr(Stdio::piped());
    let mut child = cmd.spawn().expect("spawn");
    if let Some(i) = input {
        let mut stdin = child.stdin.take().expect("stdin");
        let _ = stdin.write_all(i.as_bytes());
    }
    let mut out = child.stdout.take().expect("stdout");
    let mut err = child.stderr.take().expect("stderr");
    let t_out = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = out.read_to_string(&mut s);
        s
    });
    let t_err = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = err.read_to_string(&mut s);
        s
    });
    let start = Instant::now();
    let mut unblocked = false;
    let mut hung = false;
    let status = loop {
        if let Some(s) = child.try_wait().expect("wait") {
            break Some(s);
        }
        let t = start.elapsed();
        if !unblocked && t > Duration::from_secs(HANG_S / 2) {
            unblocked = true;
            for f in fifos {
                // Non-blocking open for writing fails with ENXIO unless a reader waits in
                // open; when one does, it is released (and then reads end of file).
                let _ = std::fs::OpenOptions::new()
                    .write(true)
                    .custom_flags_nonblock()
                    .open(f);
            }
        }
        if t > Duration::from_secs(HANG_S) {
            hung = true;
            let _ = child.kill();
            let _ = child.wait();
            break None;
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let so = t_out.join().unwrap_or_default();
    let se = t_err.join().unwrap_or_default();
    (status, so, se, hung)
}

trait NonBlock {
    fn custom_flags_nonblock(&mut self) -> &mut Self;
}

impl NonBlock for std::fs::OpenOptions {
    fn custom_flags_nonblock(&mut self) -> &mut Self {
        use std::os::unix::fs::OpenOptionsExt;
        self.custom_flags(libc::O_NONBLOCK)
    }
}

fn run_child(reader: &str, path: &Path, fifos: &[PathBuf]) -> (Outcome, Duration) {
    let mut cmd = Command::new(std::env::current_exe().expect("current_exe"));
    cmd.args([
        "--exact",
        "hostile_inputs::hostile_case_child",
        "--nocapture",
        "--test-threads=1",
    ])
    .env(CASE_ENV, format!("{reader}\t{}", path.display()))
    .env("RUST_BACKTRACE", "0");
    let start = Instant::now();
    let (status, out, err, hung) = run_bounded(cmd, None, fifos);
    let took = start.elapsed();
    if hung {
        return (Outcome::Hung, took);
    }
    let kind = out
        .lines()
        .find_map(|l| l.split_once("HOSTILE-KIND: ").map(|(_, k)| k))
        .map(str::to_string);
    let message = out
        .lines()
        .find_map(|l| l.split_once("HOSTILE-MESSAGE: ").map(|(_, m)| m))
        .map(str::to_string);
    match (kind, message) {
        (Some(kind), Some(message)) if status.is_some_and(|s| s.success()) => {
            (Outcome::Done { kind, message }, took)
        }
        _ => {
            let why = err
                .lines()
                .filter(|l| {
                    l.contains("panicked")
                        || l.contains("overflow")
                        || l.contains("memory")
                        || l.contains("error")
                })
                .take(3)
                .collect::<Vec<_>>()
                .join(" / ");
            let tail: String = err.lines().rev().take(2).collect::<Vec<_>>().join(" / ");
            (
                Outcome::Crashed(format!(
                    "{status:?}: {}",
                    if why.is_empty() { tail } else { why }
                )),
                took,
            )
        }
    }
}

fn kind_matches(kind: &str, expect: &[String]) -> bool {
    expect.iter().any(|e| match e.strip_suffix("/*") {
        Some(prefix) => kind.starts_with(&format!("{prefix}/")),
        None => e == kind,
    })
}

/// The robosim binary on the rows where it is cheap (no session): `info FILE` (model files),
/// `lang run FILE --out DIR` (programs), `query` with `{"urdf": FILE}` (URDF chains). Returns a
/// problem, if any: a panic, a hang, exit 0 on a refused file, or a message without the file.
fn cli_problem(row: &Row, path: &Path, fifos: &[PathBuf], scratch: &Path) -> Option<String> {
    let exe = env!("CARGO_BIN_EXE_robosim");
    let name = path.file_name()?.to_string_lossy().into_owned();
    let (cmd, input) = match row.reader.as_str() {
        "model" => {
            let mut c = Command::new(exe);
            c.arg("info").arg(path);
            (c, None)
        }
        "program" => {
            let mut c = Command::new(exe);
            c.args(["lang", "run"])
                .arg(path)
                .arg("--out")
                .arg(scratch.join(format!("cli-out-{}", row.line)));
            (c, None)
        }
        "urdf" => {
            let mut c = Command::new(exe);
            c.arg("query");
            let req = serde_json::json!({"id": 1, "op": "fk", "robot": {"urdf": path}, "q": []});
            (c, Some(format!("{req}\n")))
        }
        _ => return None,
    };
    let (status, out, err, hung) = run_bounded(cmd, input.as_deref(), fifos);
    if hung {
        return Some(format!(
            "robosim {}: hung (killed after {HANG_S} s)",
            row.reader
        ));
    }
    let status = status?;
    if err.contains("panicked") {
        return Some(format!(
            "robosim {}: panicked: {}",
            row.reader,
            err.lines().find(|l| l.contains("panicked")).unwrap_or("")
        ));
    }
    if row.reader == "urdf" {
        let answer: serde_json::Value = match serde_json::from_str(out.lines().next().unwrap_or(""))
        {
            Ok(a) => a,
            Err(_) => {
                return Some(format!(
                    "robosim query: no JSON answer ({status}); stderr: {}",
                    err.lines().last().unwrap_or("")
                ));
            }
        };
        if answer["ok"] != serde_json::Value::Bool(false) {
            return Some(format!("robosim query: accepted the file: {answer}"));
        }
        let kind = answer["error"]["kind"].as_str().unwrap_or("");
        let message = answer["error"]["message"].as_str().unwrap_or("");
        if kind == "internal_error" || !message.contains(&name) {
            return Some(format!(
                "robosim query: error {kind}: {message} (does not name {name})"
            ));
        }
        return None;
    }
    if status.success() {
        return Some(format!(
            "robosim {}: exit 0 on a file the API refuses",
            row.reader
        ));
    }
    if !err.contains(&name) {
        return Some(format!(
            "robosim {}: the message does not name {name}: {}",
            row.reader,
            err.trim()
        ));
    }
    None
}

#[test]
fn hostile_inputs_give_their_expected_error_kind() {
    let scratch = tempfile::tempdir().expect("tempdir");
    copy_corpus(scratch.path());
    let mut failures = Vec::new();
    let mut table = Vec::new();
    for row in rows() {
        let path = materialise(&row, scratch.path());
        let fifos: Vec<PathBuf> = {
            let mut v = Vec::new();
            for part in row.file.split('+') {
                if let Some(name) = part.strip_prefix("@fifo:") {
                    v.push(path.parent().unwrap_or(scratch.path()).join(name));
                } else if part.starts_with("@fifo.") {
                    v.push(path.clone());
                }
            }
            v
        };
        let (outcome, took) = run_child(&row.reader, &path, &fifos);
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let mut problem = match &outcome {
            Outcome::Hung => Some(format!("hung (killed after {HANG_S} s)")),
            Outcome::Crashed(why) => Some(format!("crashed: {why}")),
            Outcome::Done { kind, message } => {
                if !kind_matches(kind, &row.expect) {
                    Some(format!("got {kind}: {message}"))
                } else if !kind.starts_with("ok") && !message.contains(&name) {
                    Some(format!(
                        "{kind}, but the message does not name {name}: {message}"
                    ))
                } else {
                    None
                }
            }
        };
        // Blocked means blocked on a FIFO: the test opens its other end after HANG_S / 2 s, so a
        // row with a FIFO that ends later waited for it. A row without one is judged by its
        // outcome, and a run past HANG_S is a hang (above): a refusal that is slow on a loaded
        // machine (doubling-40.rsim builds 3 million polygons before its budget stops it,
        // 3-6 s here) is not a failure of the reader.
        if !fifos.is_empty() && took > Duration::from_secs(HANG_S / 2) {
            let blocked = format!(
                "blocked {:.1} s{}",
                took.as_secs_f64(),
                if fifos.is_empty() {
                    String::new()
                } else {
                    " until the test opened the FIFO's other end".into()
                }
            );
            problem = Some(match problem {
                Some(p) => format!("{blocked}, then {p}"),
                None => blocked,
            });
        }
        // The binary where it is cheap: on every refusal, except a model's refusal by the
        // keeper (`Tx/…`): `robosim info` describes a file without loading it.
        let cli_applies = matches!(&outcome, Outcome::Done { kind, .. }
            if !kind.starts_with("ok") && !kind.starts_with("Tx/"));
        let cli = if cli_applies && problem.is_none() {
            cli_problem(&row, &path, &fifos, scratch.path())
        } else {
            None
        };
        let verdict = match (&problem, &cli) {
            (None, None) => "pass".to_string(),
            (Some(p), _) => format!("FAIL {p}"),
            (None, Some(c)) => format!("FAIL (CLI) {c}"),
        };
        table.push(format!(
            "MANIFEST.tsv:{} {} [{}] expect {}: {verdict}",
            row.line,
            row.file,
            row.reader,
            row.expect.join("|")
        ));
        if problem.is_some() || cli.is_some() {
            failures.push(format!(
                "MANIFEST.tsv:{} {} ({}; {}): {}",
                row.line, row.file, row.reader, row.note, verdict
            ));
        }
    }
    eprintln!("{}", table.join("\n"));
    assert!(
        failures.is_empty(),
        "{} of {} hostile inputs fail:\n{}",
        failures.len(),
        table.len(),
        failures.join("\n")
    );
}
