//! Library Space → Instance Space across processes: `robosim instantiate` (a writer process)
//! fills a running keeper; a reader started late sees the whole model; `robosim set` changes
//! one parameter of one instance and the change set names objects of that instance only.

use robosim_instance_space::{Kind, Reader};
use std::collections::HashSet;
use std::process::Command;
use std::time::{Duration, Instant};

use crate::common;

use common::{Procs as Keeper, ROBOSIM};

fn robosim(k: &Keeper, args: &[&str]) -> String {
    let out = Command::new(ROBOSIM)
        .args(args)
        .args(["--session", &k.name])
        .env("ROBOSIM_HOME", k.home.path())
        .output()
        .expect("run robosim");
    let text =
        String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "robosim {args:?} failed: {text}");
    text
}

/// Ids of the subtree under object `top` (inclusive).
fn subtree(snap: &robosim_instance_space::Snapshot, top: u64) -> HashSet<u64> {
    let mut set = HashSet::from([top]);
    let mut grew = true;
    while grew {
        grew = false;
        for o in snap.objects() {
            if set.contains(&o.parent) && set.insert(o.id) {
                grew = true;
            }
        }
    }
    set
}

#[test]
fn instantiate_station_and_puma_from_other_processes_then_change_one_parameter() {
    let mut k = Keeper::new("lib");
    k.start_keeper(&[]);
    let session = k.session();
    let out = robosim(&k, &["instantiate", "space_station", "--as", "station"]);
    assert!(
        out.contains("instantiated space_station as station"),
        "{out}"
    );
    robosim(&k, &["instantiate", "puma560"]);

    // A reader started after both: the whole model at once.
    let mut reader = Reader::attach(&session, "late").expect("attach");
    let snap = reader.snapshot().expect("snapshot");
    let station = snap.find("station").expect("station instance");
    let puma = snap.find("puma560").expect("puma instance");
    let station_ids = subtree(&snap, snap.rec(station).id);
    let puma_ids = subtree(&snap, snap.rec(puma).id);
    assert!(
        station_ids.len() > 100,
        "the station has its trusses, panels, modules: {}",
        station_ids.len()
    );
    assert_eq!(snap.len(), station_ids.len() + puma_ids.len());
    let links = snap
        .objects()
        .iter()
        .filter(|o| puma_ids.contains(&o.id) && Kind::from_u32(o.kind) == Some(Kind::Link))
        .count();
    assert_eq!(links, 6, "PUMA 560 has six links");
    let polygons: usize = (0..snap.len())
        .filter_map(|i| snap.geometry(i))
        .map(|g| g.polygons.len())
        .sum();
    assert!(
        polygons > 1000,
        "every solid's polygons are mapped: {polygons}"
    );
    assert!(snap.origin(station).contains("space_station"));
    let v0 = snap.version();

    let out = robosim(&k, &["set", "station", "servicer_position=35 m"]);
    assert!(out.contains("re-instantiated station"), "{out}");
    let deadline = Instant::now() + Duration::from_secs(30);
    let mut changes = Vec::new();
    while changes.is_empty() {
        changes = reader
            .wait_change(Duration::from_millis(200))
            .expect("wait");
        assert!(Instant::now() < deadline, "no change announced");
    }
    assert_eq!(changes.len(), 1);
    assert_eq!(changes[0].version, v0 + 1);
    let touched: HashSet<u64> = changes[0].ids.iter().copied().collect();
    assert!(
        !touched.is_empty() && touched.len() < station_ids.len() / 4,
        "only what the parameter moves: {} of {}",
        touched.len(),
        station_ids.len()
    );
    assert!(
        touched.is_subset(&station_ids),
        "the change set names the station only"
    );
    assert!(touched.is_disjoint(&puma_ids));
    // Setting the same value again writes nothing but the origin record.
    let out = robosim(&k, &["set", "station", "servicer_position=35 m"]);
    assert!(out.contains("1 objects changed"), "{out}");
}

#[test]
fn a_sessions_library_space_is_shared_memory_any_process_lists_and_instantiates_from() {
    let mut k = Keeper::new("lsp");
    let file = k.home.path().join("cell.rsl");
    std::fs::write(&file, "// A fixture block for the cell.\nsolid fixture_block(size = 10 cm) {\n    part box(size, size, size / 2)\n}\n").expect("write");
    let file_arg = file.to_str().expect("utf-8 path").to_owned();
    k.start_keeper(&["--library", &file_arg]);
    let session = k.session();
    // The file is gone: other processes read the Library Space from the keeper's memory.
    std::fs::remove_file(&file).expect("remove");
    let list = robosim(&k, &["lib", "list"]);
    assert!(
        list.contains("fixture_block") && list.contains("puma560"),
        "{list}"
    );
    let show = robosim(&k, &["lib", "show", "fixture_block"]);
    assert!(show.contains("size"), "{show}");
    let out = robosim(
        &k,
        &[
            "instantiate",
            "fixture_block",
            "--as",
            "jig",
            "--set",
            "size=20 cm",
        ],
    );
    assert!(out.contains("instantiated fixture_block as jig"), "{out}");
    let reader = Reader::attach(&session, "check").expect("attach");
    let snap = reader.snapshot().expect("snapshot");
    let jig = snap.find("jig").expect("jig");
    let solid = (0..snap.len())
        .find(|&i| snap.rec(i).parent == snap.rec(jig).id)
        .expect("a part");
    let g = snap.geometry(solid).expect("geometry");
    let half = g.header.bbox[3..6].to_vec();
    assert!(
        (half[0] - 0.1).abs() < 1e-12 && (half[2] - 0.05).abs() < 1e-12,
        "20 cm block: half-diagonal {half:?}"
    );
}

/// The keeper publishes the checked library beside its source (issue 18 §3): a process
/// decodes it instead of parsing and checking the source, and gets the library the source
/// makes — the standard library plus the session's own file.
#[test]
fn a_process_reads_the_checked_library_the_keeper_published_without_parsing() {
    let mut k = Keeper::new("libchk");
    let file = k.home.path().join("fixtures.rsl");
    std::fs::write(
        &file,
        "solid fixture_block(size = 10 cm) {\n    part box(size, size, size / 2)\n}\n",
    )
    .expect("write");
    let path = file.to_string_lossy().into_owned();
    k.start_keeper(&["--library", &path]);
    let mut reader = Reader::attach(&k.session(), "lib").expect("attach");
    let published = reader.library().expect("the Library Space");
    assert!(published.checked.is_some(), "the keeper published it");
    let (lib, from) = robosim_scene::session_library_from(&mut reader).expect("library");
    assert_eq!(from, robosim_scene::LibraryFrom::Checked);
    let parsed = robosim_library::Library::from_sources(&published.files).expect("parses");
    assert_eq!(lib.declarations(), parsed.declarations());
    assert!(lib.kind("fixture_block").is_some() && lib.kind("puma560").is_some());
    assert_eq!(
        lib.evaluate(
            "fixture_block",
            &robosim_library::Params::new().expr("size", "20 cm")
        )
        .expect("evaluates"),
        parsed
            .evaluate(
                "fixture_block",
                &robosim_library::Params::new().expr("size", "20 cm")
            )
            .expect("evaluates")
    );
    // Without the encoding (a keeper of an older build): parsed, and said why.
    let source_only = robosim_instance_space::LibraryPublication {
        checked: None,
        ..published.clone()
    };
    let (again, from) = robosim_scene::library_from_publication(&source_only).expect("parses");
    assert!(
        matches!(&from, robosim_scene::LibraryFrom::Parsed { reason } if reason.contains("no checked library")),
        "{from:?}"
    );
    assert_eq!(again.declarations(), lib.declarations());
    // A damaged encoding: parsed, and the reason names the damage.
    let mut damaged = published.clone();
    if let Some(b) = damaged.checked.as_mut() {
        let last = b.len() - 1;
        b[last] ^= 0xff;
    }
    let (_, from) = robosim_scene::library_from_publication(&damaged).expect("parses");
    assert!(
        matches!(&from, robosim_scene::LibraryFrom::Parsed { reason } if reason.contains("checksum")),
        "{from:?}"
    );
}
