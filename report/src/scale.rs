//! `robosim bench scale`: does a one-body change cost the same at 10², 10³, 10⁴ and 10⁵
//! objects? For each size, in one run, against a keeper process of its own:
//!
//! * the keeper's time per one-body pose transaction, end to end (client → keeper → apply →
//!   publish → acknowledge), without the journal's fsync (which does not depend on the model's
//!   size and would hide what does);
//! * a reader following that change (`wait_change`: drain the change record and assemble the
//!   new snapshot), in this process;
//! * change-notification latency keeper → a reader blocked in another process;
//! * a late joiner's `Reader::attach` (the whole model, first snapshot);
//! * a new process's way to a usable Library Space (the standard library, against the 10²
//!   keeper): attach, receive the publication, then parse and check the source (as before)
//!   or decode the checked library the keeper publishes beside it.
//!
//! * with every body a box (a model with geometry, against a keeper of its own): a late
//!   joiner's attach, which takes every geometry from one geometry base, and a one-body
//!   geometry change (transaction, then a reader following it by the geometry update).
//!
//! Figures are reported with their ratio to the 10² model of the same run (the goal is each
//! within 1.5×). The pose path is measured on solids without geometry, so that it is measured
//! alone.

use crate::ipc::{Result, bin, keeper, stats};
use robosim_instance_space::layout::{POSE_CHUNK, PoseRec};
use robosim_instance_space::{Client, GeometryInput, IDENTITY, Kind, Reader, Transaction};
use std::fmt::Write as _;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

macro_rules! bail {
    ($($t:tt)*) => { return Err(format!($($t)*).into()) };
}

/// Model sizes (bodies, besides the scene).
pub const SIZES: [usize; 4] = [100, 1_000, 10_000, 100_000];

/// A scene of `n` solids without geometry, created 1,000 per transaction; returns the id of the
/// middle one.
pub(crate) fn build(client: &mut Client, n: usize) -> Result<u64> {
    build_with(client, n, None)
}

/// [`build`], every solid given `geometry` if some.
fn build_with(client: &mut Client, n: usize, geometry: Option<&GeometryInput>) -> Result<u64> {
    let mut tx = Transaction::new();
    tx.create(Kind::Scene, "scale", None);
    let scene = client.transact(&tx)?.created[0];
    let mut middle = 0;
    let mut k = 0;
    while k < n {
        let mut tx = Transaction::new();
        let end = (k + 1_000).min(n);
        for j in k..end {
            let b = tx.create(Kind::Solid, &format!("body{j}"), Some(scene.into()));
            if let Some(g) = geometry {
                tx.set_geometry(b, Some(g.clone()));
            }
        }
        let c = client.transact(&tx)?;
        if (k..end).contains(&(n / 2)) {
            middle = c.created[n / 2 - k];
        }
        k = end;
    }
    Ok(middle)
}

/// Moves `body` to x = `x` m (the benches' one-body pose transaction).
pub(crate) fn pose_tx(body: u64, x: f64) -> Transaction {
    let mut tx = Transaction::new();
    let mut pose = IDENTITY;
    pose[3] = x;
    tx.set_pose(body, pose);
    tx
}

/// Bytes the keeper copies into shared memory for a one-body pose transaction at `n` objects:
/// now (one pose chunk and the head) and with the whole head of before (every pose).
fn published_bytes(n: usize) -> (usize, usize) {
    let rec = std::mem::size_of::<PoseRec>();
    // A segment: 2 words, 2 words per section, the sections rounded up to words.
    let head = 8 * (2 + 4 + 5 + n.div_ceil(POSE_CHUNK));
    let chunk = 8 * (2 + 4 + 4) + POSE_CHUNK.min(n) * rec;
    let whole = 8 * (2 + 4 + 4) + n * rec;
    (head + chunk, whole)
}

/// A new process's way to a usable Library Space, in ms: (attach, receive, parse + check,
/// decode), each (mean, p50, p99); and the sizes published (source bytes, encoding bytes).
struct LibRow {
    attach: (f64, f64, f64),
    receive: (f64, f64, f64),
    parse: (f64, f64, f64),
    decode: (f64, f64, f64),
    source_bytes: usize,
    checked_bytes: usize,
    declarations: usize,
}

fn library_row(session: &robosim_instance_space::Session, reps: usize) -> Result<LibRow> {
    use robosim_library::Library;
    let ms = |t: Instant| t.elapsed().as_nanos() as f64 / 1e6;
    let (mut attach, mut receive, mut parse, mut decode) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let (mut source_bytes, mut checked_bytes, mut declarations) = (0, 0, 0);
    for _ in 0..reps {
        let t = Instant::now();
        let mut r = Reader::attach(session, "scale-library")?;
        attach.push(ms(t));
        let t = Instant::now();
        let published = r.library()?;
        receive.push(ms(t));
        let Some(checked) = &published.checked else {
            bail!("the keeper published no checked library");
        };
        let t = Instant::now();
        let parsed = Library::from_sources(&published.files)?;
        parse.push(ms(t));
        let t = Instant::now();
        let decoded = Library::decode_checked(checked, &published.files)
            .map_err(|e| format!("the published checked library: {e}"))?;
        decode.push(ms(t));
        if decoded.declarations() != parsed.declarations() {
            bail!("the decoded library lists other declarations than the parsed one");
        }
        source_bytes = published.files.iter().map(|(n, t)| n.len() + t.len()).sum();
        checked_bytes = checked.len();
        declarations = parsed.declarations().len();
    }
    Ok(LibRow {
        attach: stats(attach),
        receive: stats(receive),
        parse: stats(parse),
        decode: stats(decode),
        source_bytes,
        checked_bytes,
        declarations,
    })
}

struct Row {
    n: usize,
    tx: (f64, f64, f64),
    follow: (f64, f64, f64),
    notify: (f64, f64, f64),
    /// The bare iceoryx2 event between two processes, beside `notify`.
    event: (f64, f64, f64),
    attach: (f64, f64, f64),
    /// Per round: (pose tx p50, reader follows p50, notify p50, attach, bare event p50).
    rounds: Vec<[f64; 5]>,
    geometry: GeomRow,
}

/// The model of boxes: attach (ms), one-body geometry change tx and follow (µs), the geometry
/// base's size (bytes).
struct GeomRow {
    /// The first joiner (the keeper builds the geometry and objects bases for it), ms.
    attach_first: f64,
    /// The joiners after it (the bases from the services' histories).
    attach: (f64, f64, f64),
    tx: (f64, f64, f64),
    follow: (f64, f64, f64),
    /// One box created (appended to the scene): the keeper's transaction, a reader following.
    create_tx: (f64, f64, f64),
    create_follow: (f64, f64, f64),
    base_bytes: usize,
}

/// A box of sides `s` (m), as a transaction's geometry.
fn cube(s: f64) -> Result<GeometryInput> {
    let p = robosim_geometry::shapes::cuboid(s, s, s)?;
    Ok(GeometryInput::from_polyhedron(&p))
}

/// The model of `n` boxes: late joiners, and one box's geometry changed and followed.
/// Commits `tx` and waits until `follower` has its version: what the keeper answered, the
/// transaction's time and the follower's (µs).
fn commit_and_follow(
    client: &mut Client,
    follower: &mut Reader,
    tx: &Transaction,
) -> Result<(robosim_instance_space::Applied, f64, f64)> {
    let t = Instant::now();
    let c = client.transact(tx)?;
    let tx_time = t.elapsed().as_nanos() as f64 / 1e3;
    let t = Instant::now();
    while follower.snapshot().is_none_or(|s| s.version() < c.version) {
        follower.wait_change(Duration::from_secs(5))?;
    }
    Ok((c, tx_time, t.elapsed().as_nanos() as f64 / 1e3))
}

fn geometry_row(name: &str, n: usize, attach_reps: usize, reps: usize) -> Result<GeomRow> {
    let kp = keeper(name, false)?;
    let mut client = Client::connect(kp.session(), "scale-writer")?;
    let body = build_with(&mut client, n, Some(&cube(0.1)?))?;
    let mut attach_ms = Vec::with_capacity(attach_reps);
    let mut base_bytes = 0;
    for _ in 0..attach_reps {
        let t = Instant::now();
        let r = Reader::attach(kp.session(), "scale-joiner")?;
        attach_ms.push(t.elapsed().as_nanos() as f64 / 1e6);
        let snap = r.snapshot().ok_or("no snapshot")?;
        let boxes = (0..snap.len())
            .filter(|&i| snap.geometry(i).is_some())
            .count();
        // At most one request: a base the keeper published for an earlier joiner may reach
        // this one from the service's history before it needs to ask.
        if boxes != n || r.geometry_bases_asked() > 1 {
            bail!(
                "a late joiner saw {boxes} of {n} boxes, asking {} times for a geometry base",
                r.geometry_bases_asked()
            );
        }
        base_bytes = 8 * r.geometry_base_words();
    }
    let mut follower = Reader::attach(kp.session(), "scale-follower")?;
    // 0 or 1: a base published for a joiner above may reach it from the service's history.
    let asked_to_attach = follower.geometry_bases_asked();
    let (mut tx_us, mut follow_us) = (Vec::with_capacity(reps), Vec::with_capacity(reps));
    for k in 0..reps + 20 {
        let side = 0.1 + (k % 7 + 1) as f64 * 0.01;
        let mut tx = Transaction::new();
        tx.set_geometry(body, Some(cube(side)?));
        let (_, tx_time, follow_time) = commit_and_follow(&mut client, &mut follower, &tx)?;
        let snap = follower.snapshot().ok_or("no snapshot")?;
        let g = snap
            .index_of(body)
            .and_then(|i| snap.geometry(i))
            .ok_or("the changed box has no geometry")?;
        let x = g.vertices.iter().map(|v| v[0]).fold(f64::MIN, f64::max);
        if (x - side / 2.0).abs() > 1e-12 {
            bail!("the follower has a stale geometry at {n} boxes");
        }
        // The first changes warm up pages and caches.
        if k >= 20 {
            tx_us.push(tx_time);
            follow_us.push(follow_time);
        }
    }
    if follower.geometry_bases_asked() != asked_to_attach {
        bail!("the follower asked for a geometry base again at {n} boxes");
    }
    // One box created at a time: appended to the last object chunk.
    let scene = {
        let snap = follower.snapshot().ok_or("no snapshot")?;
        snap.rec(snap.index_of(body).ok_or("body missing")?).parent
    };
    let asked = follower.objects_bases_asked();
    let (mut create_us, mut create_follow_us) =
        (Vec::with_capacity(reps), Vec::with_capacity(reps));
    for k in 0..reps + 20 {
        let mut tx = Transaction::new();
        let b = tx.create(Kind::Solid, &format!("added{k}"), Some(scene.into()));
        tx.set_geometry(b, Some(cube(0.05)?));
        let (c, tx_time, follow_time) = commit_and_follow(&mut client, &mut follower, &tx)?;
        let snap = follower.snapshot().ok_or("no snapshot")?;
        let added = c.created.first().copied().ok_or("nothing created")?;
        let i = snap.index_of(added).ok_or("the created box is missing")?;
        if i + 1 != snap.len() || snap.geometry(i).is_none() || snap.len() != n + 2 + k {
            bail!("the follower has not the created box at the end at {n} boxes");
        }
        if k >= 20 {
            create_us.push(tx_time);
            create_follow_us.push(follow_time);
        }
    }
    if follower.objects_bases_asked() != asked {
        bail!("the follower asked for an objects base while following creates at {n} boxes");
    }
    Ok(GeomRow {
        attach_first: attach_ms.first().copied().unwrap_or(f64::NAN),
        attach: stats(attach_ms.get(1..).unwrap_or(&[]).to_vec()),
        tx: stats(tx_us),
        follow: stats(follow_us),
        create_tx: stats(create_us),
        create_follow: stats(create_follow_us),
        base_bytes,
    })
}

/// One model of the pose path: its keeper, the writer, the in-process follower, and the
/// samples gathered over the rounds.
struct PoseModel {
    n: usize,
    kp: robosim_instance_space::ScratchKeeper,
    client: Client,
    follower: Reader,
    body: u64,
    /// Pose transactions committed so far (the next one moves the body to x = (k + 1) mm).
    k: usize,
    tx_us: Vec<f64>,
    follow_us: Vec<f64>,
    notify_us: Vec<f64>,
    event_us: Vec<f64>,
    attach_ms: Vec<f64>,
    /// Per round: (pose tx p50, reader follows p50, notify p50, attach, bare event p50), for
    /// the ratios.
    rounds: Vec<[f64; 5]>,
}

impl PoseModel {
    fn start(name: &str, n: usize) -> Result<PoseModel> {
        let kp = keeper(name, false)?;
        let mut client = Client::connect(kp.session(), "scale-writer")?;
        let body = build(&mut client, n)?;
        let follower = Reader::attach(kp.session(), "scale-follower")?;
        let mut m = PoseModel {
            n,
            kp,
            client,
            follower,
            body,
            k: 0,
            tx_us: Vec::new(),
            follow_us: Vec::new(),
            notify_us: Vec::new(),
            event_us: Vec::new(),
            attach_ms: Vec::new(),
            rounds: Vec::new(),
        };
        // Warm-up: first touch of shared-memory pages is not what this measures.
        m.pose_batch(200, false)?;
        Ok(m)
    }

    /// `count` one-body pose transactions, each followed by the in-process follower; the
    /// times recorded if `record`. Returns the medians of this batch (tx, follow).
    fn pose_batch(&mut self, count: usize, record: bool) -> Result<(f64, f64)> {
        let (mut tx_us, mut follow_us) = (Vec::with_capacity(count), Vec::with_capacity(count));
        let n = self.n;
        for _ in 0..count {
            self.k += 1;
            let x = tx_pose_x(self.k);
            let t = Instant::now();
            let c = self.client.transact(&pose_tx(self.body, x))?;
            tx_us.push(t.elapsed().as_nanos() as f64 / 1e3);
            let t = Instant::now();
            let changes = self.follower.wait_change(Duration::from_secs(5))?;
            follow_us.push(t.elapsed().as_nanos() as f64 / 1e3);
            let snap = self.follower.snapshot().ok_or("no snapshot")?;
            if changes.last().map(|c| c.version) != Some(c.version) || snap.version() != c.version {
                bail!(
                    "the follower did not reach version {} at {n} bodies",
                    c.version
                );
            }
            let i = snap.index_of(self.body).ok_or("body missing")?;
            if snap.pose(i).pose[3] != x {
                bail!("the follower's snapshot has a stale pose at {n} bodies");
            }
        }
        let medians = (stats(tx_us.clone()).1, stats(follow_us.clone()).1);
        if record {
            self.tx_us.extend(tx_us);
            self.follow_us.extend(follow_us);
        }
        Ok(medians)
    }

    /// Notification latency of `count` pose transactions, one every 300 µs, to a reader
    /// process of this round blocked in `wait_event`; the follower catches up afterwards,
    /// untimed. Returns this batch's median (µs).
    fn notify_batch(&mut self, count: usize, tag: &str) -> Result<f64> {
        let n = self.n;
        let lat_path = std::env::temp_dir().join(format!("robosim-scale-lat-{tag}.txt"));
        let mut reader = Command::new(bin()?)
            .args([
                "bench",
                "ipc-reader",
                "--session",
                self.kp.session().name(),
                "--count",
                &count.to_string(),
                "--out",
            ])
            .arg(&lat_path)
            .stdout(Stdio::piped())
            .spawn()?;
        let mut line = String::new();
        use std::io::BufRead;
        if let Some(o) = reader.stdout.as_mut() {
            std::io::BufReader::new(o).read_line(&mut line)?;
        }
        if line.trim() != "ready" {
            let _ = reader.kill();
            let _ = reader.wait();
            bail!("the latency reader at {n} bodies did not attach");
        }
        for _ in 0..count {
            // The writer alone: the in-process follower does not follow in this phase, so the
            // latency reader shares the two cores with the keeper only (with it, a second
            // reader assembling every version at the same moment made this figure a
            // measure of CPU contention, growing with its O(chunks) work).
            self.k += 1;
            self.client
                .transact(&pose_tx(self.body, tx_pose_x(self.k)))?;
            // Let the reader block again, so every sample is a wake-up from sleep.
            std::thread::sleep(Duration::from_micros(300));
        }
        let status = reader.wait()?;
        let text = std::fs::read_to_string(&lat_path).unwrap_or_default();
        let _ = std::fs::remove_file(&lat_path);
        if !status.success() {
            bail!("latency reader failed at {n} bodies: {status}");
        }
        let lat: Vec<f64> = text.lines().filter_map(|l| l.parse().ok()).collect();
        if lat.len() != count {
            bail!(
                "the latency reader at {n} bodies recorded {} of {count} changes",
                lat.len()
            );
        }
        let median = stats(lat.clone()).1;
        self.notify_us.extend(lat);
        // Untimed: the follower drains what it did not follow.
        let version = self
            .client
            .transact(&pose_tx(self.body, tx_pose_x(self.k)))?
            .version;
        while self
            .follower
            .snapshot()
            .is_none_or(|s| s.version() < version)
        {
            self.follower.wait_change(Duration::from_secs(5))?;
        }
        Ok(median)
    }

    /// The baseline of [`PoseModel::notify_batch`]: `count` notifications of a bare iceoryx2
    /// event (no keeper, no transaction, nothing of the Instance Space in between), one every
    /// 300 µs, to a listener process of this round blocked in its wait; CLOCK_MONOTONIC before
    /// the notify → after the wake-up. Returns this batch's median (µs).
    fn event_batch(&mut self, count: usize, tag: &str) -> Result<f64> {
        use robosim_instance_space::bare_event::BareNotifier;
        let n = self.n;
        let session = self.kp.session();
        let mut notifier = BareNotifier::create(session, tag)?;
        let out = std::env::temp_dir().join(format!("robosim-scale-event-{tag}.txt"));
        let mut listener = Command::new(bin()?)
            .args([
                "bench",
                "ipc-reader",
                "--session",
                session.name(),
                "--count",
                &count.to_string(),
                "--bare",
                tag,
                "--out",
            ])
            .arg(&out)
            .stdout(Stdio::piped())
            .spawn()?;
        let mut line = String::new();
        use std::io::BufRead;
        if let Some(o) = listener.stdout.as_mut() {
            std::io::BufReader::new(o).read_line(&mut line)?;
        }
        if line.trim() != "ready" || notifier.listeners() == 0 {
            let _ = listener.kill();
            let _ = listener.wait();
            bail!("the bare event listener at {n} bodies did not start listening");
        }
        let mut sent = Vec::with_capacity(count);
        for _ in 0..count {
            sent.push(notifier.notify()?);
            std::thread::sleep(Duration::from_micros(300));
        }
        let status = listener.wait()?;
        let text = std::fs::read_to_string(&out).unwrap_or_default();
        let _ = std::fs::remove_file(&out);
        if !status.success() {
            bail!("the bare event listener at {n} bodies failed: {status}");
        }
        let woke: Vec<u64> = text.lines().filter_map(|l| l.parse().ok()).collect();
        if woke.len() != count {
            bail!(
                "the bare event listener at {n} bodies woke {} times for {count} events",
                woke.len()
            );
        }
        let lat: Vec<f64> = woke
            .iter()
            .zip(&sent)
            .map(|(w, s)| w.saturating_sub(*s) as f64 / 1e3)
            .collect();
        let median = stats(lat.clone()).1;
        self.event_us.extend(lat);
        Ok(median)
    }

    /// One late joiner's attach (ms).
    fn attach(&mut self) -> Result<f64> {
        let t = Instant::now();
        let r = Reader::attach(self.kp.session(), "scale-joiner")?;
        let ms = t.elapsed().as_nanos() as f64 / 1e6;
        let len = r.snapshot().map_or(0, |s| s.len());
        if len != self.n + 1 {
            bail!("a late joiner saw {len} objects, not {}", self.n + 1);
        }
        self.attach_ms.push(ms);
        Ok(ms)
    }
}

/// Runs the bench and writes `scale.md` and `scale.csv` into `out`.
///
/// The pose path is measured in rounds over the four models at once, each against a keeper of
/// its own: in every round each model in turn (the order rotating) takes a batch of pose
/// transactions, a batch of notifications and one late joiner. A load that comes and goes on
/// this shared machine then falls on every size alike, and each round gives its own ratios to
/// the 10² model, whose spread is reported beside the pooled figures.
pub fn run(out: &Path, quick: bool) -> Result<()> {
    let rounds = if quick { 3 } else { 10 };
    let tx_batch = if quick { 100 } else { 300 };
    let lat_batch = if quick { 100 } else { 200 };
    let pid = std::process::id();
    let mut models = Vec::new();
    let mut lib = None;
    for n in SIZES {
        // Short session names: iceoryx2 limits the length of the names derived from them.
        let m = PoseModel::start(&format!("sc{pid}n{n}"), n)?;
        if lib.is_none() {
            lib = Some(library_row(m.kp.session(), if quick { 5 } else { 20 })?);
        }
        models.push(m);
    }
    for round in 0..rounds {
        for j in 0..models.len() {
            let m = &mut models[(j + round) % SIZES.len()];
            let (tx, follow) = m.pose_batch(tx_batch, true)?;
            let notify = m.notify_batch(lat_batch, &format!("{pid}-{}-{round}", m.n))?;
            let event = m.event_batch(lat_batch, &format!("{pid}-{}-{round}", m.n))?;
            let attach = m.attach()?;
            m.rounds.push([tx, follow, notify, attach, event]);
        }
    }
    let mut rows = Vec::new();
    for m in models {
        let PoseModel {
            n,
            kp,
            client,
            follower,
            tx_us,
            follow_us,
            notify_us,
            event_us,
            attach_ms,
            rounds,
            ..
        } = m;
        drop((client, follower, kp));
        let geometry = geometry_row(
            &format!("sg{pid}n{n}"),
            n,
            if quick { 3 } else { 10 },
            if quick { 30 } else { 200 },
        )?;
        rows.push(Row {
            n,
            tx: stats(tx_us),
            follow: stats(follow_us),
            notify: stats(notify_us),
            event: stats(event_us),
            attach: stats(attach_ms),
            rounds,
            geometry,
        });
    }
    let lib = lib.ok_or("no library measurement")?;
    write(out, quick, &rows, &lib)
}

fn tx_pose_x(k: usize) -> f64 {
    k as f64 * 1e-3
}

fn write(out: &Path, quick: bool, rows: &[Row], lib: &LibRow) -> Result<()> {
    let base = &rows[0];
    let mut doc = Doc {
        md: String::new(),
        csv: String::from("measure,bodies,value,unit\n"),
    };
    write_header(&mut doc, quick, base);
    write_pose_table(&mut doc, rows, base);
    write_geometry_table(&mut doc, rows, base);
    write_library_table(&mut doc, lib);
    let Doc { md, csv } = &doc;
    std::fs::create_dir_all(out)?;
    std::fs::write(out.join("scale.md"), md)?;
    std::fs::write(out.join("scale.csv"), csv)?;
    print!("{md}");
    Ok(())
}

/// The page and the CSV of its figures, filled section by section.
struct Doc {
    md: String,
    csv: String,
}

/// The title, the build and how the rounds are run; `base` is the 10² model's row.
fn write_header(doc: &mut Doc, quick: bool, base: &Row) {
    let Doc { md, .. } = doc;
    writeln!(
        md,
        "# Costs that follow the change (`robosim bench scale{}`)\n",
        if quick { " --quick" } else { "" }
    )
    .ok();
    let rounds = base.rounds.len();
    let build = if cfg!(debug_assertions) {
        "a debug build (our crates at opt-level 1, dependencies at 2): figures are slower than a release build's, and ratios between sizes are what to read"
    } else {
        "a release build"
    };
    writeln!(md, "Built as {build}.\n").ok();
    writeln!(md, "Measured on this machine (2 cores, shared), one run of {rounds} rounds. The four models run at once, each against a keeper of its own, and every round gives each model in turn (the order rotating) a batch of pose transactions, a batch of notifications and one late joiner: a load that comes and goes on this shared machine falls on every size alike. **×10²** is the ratio of the pooled median to the 10² model's, with in brackets the least and greatest ratio of one round's medians (goal: each ≤ 1.5 at 10⁵). Bodies are solids without geometry under one scene; one body in the middle is moved by one `SetPose` transaction at a time. The keeper runs without the journal's fsync (a constant ≈ 130 µs here, docs/bench/ipc.md (d)) so that what grows with the model is not hidden.\n").ok();
    writeln!(md, "* **pose tx**: `Client::transact`, end to end through the keeper process (apply, publish one pose chunk of {POSE_CHUNK} records and the head, acknowledge);").ok();
    writeln!(md, "* **reader follows**: `Reader::wait_change` right after the acknowledgement, in this process: drain the change record and assemble the new snapshot (receive the one changed chunk; reuse the others);").ok();
    writeln!(md, "* **notify**: keeper's publish stamp → a reader process blocked in `wait_event` wakes (CLOCK_MONOTONIC), one pose transaction every 300 µs, a new reader process each round; the writer does not follow in this phase (until stop 34 it did: a second reader assembling each version at the same moment, on two cores);").ok();
    writeln!(md, "* **iceoryx2 event**: the baseline of *notify*, measured right after it in every round and model: a bare iceoryx2 event between this process and a listener process of the round (same iceoryx2 configuration, one `notify` every 300 µs, no keeper, no transaction, no sample in between), stamped before the `notify` and at the wake-up; **notify / event** is the ratio of the pooled p50s (in brackets the least and greatest ratio of one round's p50s) — what robosim adds to iceoryx2's own wake-up;").ok();
    writeln!(
        md,
        "* **attach**: a late joiner's `Reader::attach` until its first snapshot (the whole model), one per round;"
    )
    .ok();
    writeln!(md, "* **bytes published**: what the keeper copies into shared memory per one-body pose transaction, computed from the layout — now, and with the whole pose head republished per commit as before.\n").ok();
}

/// The table of the models without geometry: pose transaction, reader follows, notify against
/// the bare iceoryx2 event, attach and bytes published; ratios against `base` (the 10² model).
fn write_pose_table(doc: &mut Doc, rows: &[Row], base: &Row) {
    let Doc { md, csv } = doc;
    writeln!(md, "| bodies | pose tx p50 / p99 (µs) | ×10² | reader follows p50 / p99 (µs) | ×10² | notify p50 / p99 (µs) | ×10² | iceoryx2 event p50 / p99 (µs) | notify / event | attach p50 / max (ms) | ×10² | bytes published now / whole head |\n|---|---|---|---|---|---|---|---|---|---|---|---|").ok();
    for r in rows {
        let (now, whole) = published_bytes(r.n);
        let ratio = |i: usize, pooled: f64, pooled_base: f64| {
            let per: Vec<f64> = r
                .rounds
                .iter()
                .zip(&base.rounds)
                .map(|(a, b)| a[i] / b[i])
                .collect();
            let lo = per.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = per.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            (pooled / pooled_base, lo, hi)
        };
        let cell = |(p, lo, hi): (f64, f64, f64)| format!("{p:.2} [{lo:.2}–{hi:.2}]");
        let tx = ratio(0, r.tx.1, base.tx.1);
        let follow = ratio(1, r.follow.1, base.follow.1);
        let notify = ratio(2, r.notify.1, base.notify.1);
        let attach = ratio(3, r.attach.1, base.attach.1);
        let attach_max = r.rounds.iter().map(|x| x[3]).fold(0.0, f64::max);
        let over: Vec<f64> = r.rounds.iter().map(|x| x[2] / x[4]).collect();
        let over = (
            r.notify.1 / r.event.1,
            over.iter().copied().fold(f64::INFINITY, f64::min),
            over.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        );
        writeln!(
            md,
            "| {} | {:.1} / {:.1} | {} | {:.1} / {:.1} | {} | {:.1} / {:.1} | {} | {:.1} / {:.1} | {} | {:.2} / {:.2} | {} | {} / {} |",
            r.n,
            r.tx.1,
            r.tx.2,
            cell(tx),
            r.follow.1,
            r.follow.2,
            cell(follow),
            r.notify.1,
            r.notify.2,
            cell(notify),
            r.event.1,
            r.event.2,
            cell(over),
            r.attach.1,
            attach_max,
            cell(attach),
            now,
            whole
        )
        .ok();
        for (m, v, u) in [
            ("pose_tx_mean", r.tx.0, "us"),
            ("pose_tx_p50", r.tx.1, "us"),
            ("pose_tx_p99", r.tx.2, "us"),
            ("pose_tx_ratio", tx.0, "x"),
            ("pose_tx_ratio_round_max", tx.2, "x"),
            ("reader_follow_mean", r.follow.0, "us"),
            ("reader_follow_p50", r.follow.1, "us"),
            ("reader_follow_p99", r.follow.2, "us"),
            ("reader_follow_ratio", follow.0, "x"),
            ("notify_p50", r.notify.1, "us"),
            ("notify_p99", r.notify.2, "us"),
            ("notify_ratio", notify.0, "x"),
            ("notify_ratio_round_max", notify.2, "x"),
            ("event_p50", r.event.1, "us"),
            ("event_p99", r.event.2, "us"),
            ("notify_over_event", over.0, "x"),
            ("attach_mean", r.attach.0, "ms"),
            ("attach_p50", r.attach.1, "ms"),
            ("attach_ratio", attach.0, "x"),
            ("attach_ratio_round_max", attach.2, "x"),
            ("published_bytes", now as f64, "B"),
            ("whole_head_bytes", whole as f64, "B"),
        ] {
            writeln!(csv, "{m},{},{v:.3},{u}", r.n).ok();
        }
    }
}

/// "A model with geometry": joiners, geometry and create transactions and their followers;
/// ratios against `base` (the 10² model).
fn write_geometry_table(doc: &mut Doc, rows: &[Row], base: &Row) {
    let Doc { md, csv } = doc;
    writeln!(md, "\n## A model with geometry\n").ok();
    writeln!(md, "The same sizes with every body a box (8 vertices, 6 faces), against a keeper of its own. A late joiner asks the keeper at most once for the **geometry base** (every object's geometry in one sample, kept in shared memory and viewed in place) — the model's geometry travels in two iceoryx2 services whatever the number of objects, where it had one per object before (a service costs milliseconds to make and to open). A **one-body geometry change** (`SetGeometry` on the middle box) goes by the **geometry update** (the changed geometry alone) and republishes the one **object chunk** (256 objects' records) whose record changed, with one generation word per chunk; a **box created** (one `Create` + `SetGeometry`, appended after the last object) republishes the last object chunk. A late joiner takes the object chunks from one **objects base**; a follower asks for none (checked). **First joiner**: the keeper builds the geometry and objects bases for it; **later joiners** find them in the services' histories (p50 of the others).\n").ok();
    writeln!(md, "| bodies | first joiner (ms) | later joiners p50 (ms) | ×10² | geometry base (MB) | geometry tx mean / p50 / p99 (µs) | ×10² | reader follows mean / p50 / p99 (µs) | ×10² | create tx mean / p50 / p99 (µs) | ×10² | reader follows create mean / p50 / p99 (µs) | ×10² |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|").ok();
    let gb = &base.geometry;
    for r in rows {
        let g = &r.geometry;
        writeln!(
            md,
            "| {} | {:.2} | {:.2} | {:.2} | {:.1} | {:.1} / {:.1} / {:.1} | {:.2} | {:.1} / {:.1} / {:.1} | {:.2} | {:.1} / {:.1} / {:.1} | {:.2} | {:.1} / {:.1} / {:.1} | {:.2} |",
            r.n,
            g.attach_first,
            g.attach.1,
            g.attach.1 / gb.attach.1,
            g.base_bytes as f64 / 1e6,
            g.tx.0,
            g.tx.1,
            g.tx.2,
            g.tx.0 / gb.tx.0,
            g.follow.0,
            g.follow.1,
            g.follow.2,
            g.follow.0 / gb.follow.0,
            g.create_tx.0,
            g.create_tx.1,
            g.create_tx.2,
            g.create_tx.0 / gb.create_tx.0,
            g.create_follow.0,
            g.create_follow.1,
            g.create_follow.2,
            g.create_follow.0 / gb.create_follow.0,
        )
        .ok();
        for (m, v, u) in [
            ("geometry_attach_first", g.attach_first, "ms"),
            ("geometry_attach_p50", g.attach.1, "ms"),
            ("geometry_base_bytes", g.base_bytes as f64, "B"),
            ("geometry_tx_mean", g.tx.0, "us"),
            ("geometry_tx_p50", g.tx.1, "us"),
            ("geometry_follow_p50", g.follow.1, "us"),
            ("create_tx_p50", g.create_tx.1, "us"),
            ("create_follow_p50", g.create_follow.1, "us"),
            ("geometry_tx_p99", g.tx.2, "us"),
            ("geometry_follow_mean", g.follow.0, "us"),
            ("geometry_follow_p99", g.follow.2, "us"),
            ("create_tx_mean", g.create_tx.0, "us"),
            ("create_tx_p99", g.create_tx.2, "us"),
            ("create_follow_mean", g.create_follow.0, "us"),
            ("create_follow_p99", g.create_follow.2, "us"),
        ] {
            writeln!(csv, "{m},{},{v:.3},{u}", r.n).ok();
        }
    }
}

/// "A new process's Library Space": attach, receive, parse against decode; and the footer.
fn write_library_table(doc: &mut Doc, lib: &LibRow) {
    let Doc { md, csv } = doc;
    writeln!(md, "\n## A new process's Library Space\n").ok();
    writeln!(md, "The standard library ({} declarations, {} bytes of source) as a process gets it from the 10² session: `Reader::attach`, then `Reader::library` (the keeper's publication: the source files and the checked library's encoding, {} bytes), then either **parse + check** the source (`Library::from_sources`, what every process did before) or **decode** the encoding (`Library::decode_checked`: digest and checksum compared, the declarations' syntax trees read; nothing parsed or evaluated). The two libraries are compared (same declarations) on every repetition.\n", lib.declarations, lib.source_bytes, lib.checked_bytes).ok();
    writeln!(
        md,
        "| step | mean (ms) | p50 (ms) | p99 (ms) |\n|---|---|---|---|"
    )
    .ok();
    for (name, key, v) in [
        ("attach", "library_attach", lib.attach),
        ("receive the publication", "library_receive", lib.receive),
        ("parse + check the source", "library_parse", lib.parse),
        ("decode the checked library", "library_decode", lib.decode),
    ] {
        writeln!(md, "| {name} | {:.2} | {:.2} | {:.2} |", v.0, v.1, v.2).ok();
        writeln!(csv, "{key}_mean,100,{:.4},ms", v.0).ok();
        writeln!(csv, "{key}_p99,100,{:.4},ms", v.2).ok();
    }
    let before = lib.attach.0 + lib.receive.0 + lib.parse.0;
    let after = lib.attach.0 + lib.receive.0 + lib.decode.0;
    writeln!(md, "\nAttach to a usable library (means): **{before:.1} ms** parsing, **{after:.1} ms** decoding ({:.2}× ; the library alone: {:.1}× faster).", after / before, lib.parse.0 / lib.decode.0).ok();
    writeln!(csv, "library_usable_parse,100,{before:.4},ms").ok();
    writeln!(csv, "library_usable_decode,100,{after:.4},ms").ok();
    writeln!(
        md,
        "\nRegenerate: `cargo run --release -- bench scale --out docs/bench`."
    )
    .ok();
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn published_bytes_follow_the_layout() {
        // 10⁵ objects: 391 chunks; head 11 + 391 words, chunk 10 words + 256 records.
        let (now, whole) = published_bytes(100_000);
        assert_eq!(now, 8 * (11 + 391) + 80 + 256 * 112);
        assert_eq!(whole, 80 + 100_000 * 112);
        // A model smaller than a chunk publishes its records once, as before, plus the head.
        let (now, whole) = published_bytes(100);
        assert_eq!(now - 8 * 12, whole);
    }
}
