//! `robosim demo` end to end: the built binary, a private ROBOSIM_HOME, real keeper and
//! simulator processes. The assertions read the demo's own account and check the numbers it
//! reports: IK solutions with small residuals, a collision-free one chosen, every MOVEJI version
//! seen by the reader in order, the tool where IK put it, the simulator's state at the goal, the
//! held arm staying put, the ECLSS fault isolated, the NaN pose refused.

use std::process::Command;

const ROBOSIM: &str = env!("CARGO_BIN_EXE_robosim");

/// The first line containing `marker`, or a failure showing the whole output.
fn line<'a>(out: &'a str, marker: &str) -> &'a str {
    out.lines()
        .find(|l| l.contains(marker))
        .unwrap_or_else(|| panic!("no line with {marker:?} in:\n{out}"))
}

/// The number right after the first `key` in `text`.
fn number_after(text: &str, key: &str) -> f64 {
    let at = text
        .find(key)
        .unwrap_or_else(|| panic!("{key:?} not in {text:?}"))
        + key.len();
    let rest = text[at..].trim_start();
    let end = rest
        .find(|c: char| !(c.is_ascii_digit() || "+-.e".contains(c)))
        .unwrap_or(rest.len());
    // The longest prefix that parses: `2..=31` is 2.
    (1..=end)
        .rev()
        .find_map(|n| rest[..n].parse().ok())
        .unwrap_or_else(|| panic!("no number after {key:?} in {text:?}"))
}

#[test]
fn demo_runs_the_whole_system_and_reports_real_numbers() {
    let home = tempfile::tempdir().expect("temp dir");
    let out = Command::new(ROBOSIM)
        .arg("demo")
        .env("ROBOSIM_HOME", home.path())
        .env("IOX2_LOG_LEVEL", "Error")
        .output()
        .expect("run robosim demo");
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success(),
        "demo failed: {:?}\nstdout:\n{stdout}\nstderr:\n{stderr}",
        out.status
    );

    // 2. the mapped model agrees with the Library Space.
    line(&stdout, "= the Library Space evaluation");

    // 3. analytic IK: several solutions, all at rounding-level residual.
    let ik = line(&stdout, "analytic IK");
    assert!(number_after(ik, "all solutions):") >= 2.0, "{ik}");
    assert!(number_after(ik, "worst residual") < 1e-9, "{ik}");

    // 4. a collision-free solution with a clear path was chosen; the per-solution lines name
    // the verdict of each.
    let chosen = line(&stdout, "chosen:");
    let label = chosen["chosen:".len()..]
        .trim_start()
        .split(',')
        .next()
        .expect("a label");
    let sol = stdout
        .lines()
        .find(|l| l.trim_start().starts_with(&format!("{label} q ")))
        .unwrap_or_else(|| panic!("no solution line for {label}:\n{stdout}"));
    assert!(sol.ends_with("clear"), "{sol}");
    assert!(sol.contains("in limits"), "{sol}");

    // The seed's sweep over the head: all 861 points accounted for, some reached.
    let sweep = line(&stdout, "seed's sweep");
    let points = number_after(sweep, "seed's sweep,");
    let reached = number_after(sweep, "ms:");
    let out_of_reach = number_after(sweep, "of the head,");
    let blocked = number_after(sweep, "out of reach,");
    assert_eq!(points, 41.0 * 21.0, "{sweep}");
    assert!(reached > 0.0, "{sweep}");
    assert_eq!(reached + out_of_reach + blocked, points, "{sweep}");
    let worst = line(&stdout, "position bound over the reached points:");
    assert!(number_after(worst, "reached points:") > 0.0, "{worst}");

    // 5. every MOVEJI transaction reached the reader, in order, naming only the links.
    let moved = line(&stdout, "transactions in");
    let steps = number_after(moved, "");
    let seen = number_after(moved, "the reader saw");
    assert_eq!(seen, steps, "{moved}");
    assert!(
        moved.contains("in order") && !moved.contains("OUT OF ORDER"),
        "{moved}"
    );
    let first = number_after(moved, "versions");
    let last = number_after(moved, "..=");
    assert_eq!(last - first + 1.0, steps, "{moved}");
    // The tool is where IK put it, read back from shared memory.
    let tip = line(&stdout, "off the target by");
    assert!(number_after(tip, "off the target by") < 1e-9, "{tip}");

    // 6. the simulator's state is at the goal.
    let st = line(&stdout, "differ from the goal by");
    assert!(number_after(st, "differ from the goal by") < 1e-9, "{st}");

    // 7. the encoder bound is positive and the exact worst case does not exceed it.
    let enc = line(&stdout, "tool position error ≤");
    let bound = number_after(enc, "tool position error ≤");
    let worst = number_after(enc, "exact worst case");
    assert!(bound > 0.0 && worst <= bound * (1.0 + 1e-9), "{enc}");

    // 8. gravity torques are the potential energy's gradient and hold the arm: it stays put;
    // unpowered it falls, energy conserved.
    let g = line(&stdout, "g(q) =");
    assert!(number_after(g, "potential energy) to") < 1e-6, "{g}");
    let held = line(&stdout, "held by g(q)");
    assert!(number_after(held, "the arm drifts") < 1e-6, "{held}");
    assert!(number_after(held, "unpowered it falls") > 1e-3, "{held}");
    assert!(number_after(held, "energy change").abs() < 1e-6, "{held}");

    // 9. the injected ECLSS fault is isolated without its own alarm.
    let diag = line(&stdout, "diagnosis (FSPI");
    assert!(diag.contains("sorbent_bed_failure"), "{diag}");
    assert!(diag.contains("fault isolated"), "{diag}");
    // …and the stated limit: two failed sensors leave an ambiguity group containing the fault.
    let limit = line(&stdout, "limit: valve_stuck");
    assert!(number_after(limit, "alarms leave") >= 2.0, "{limit}");
    assert!(
        limit.contains("valve_stuck,") || limit.contains("valve_stuck)"),
        "{limit}"
    );

    // 10. the NaN pose was refused and the model did not move past the last MOVEJI version.
    line(&stdout, "refused:");
    let still = line(&stdout, "model still at version");
    assert_eq!(
        number_after(still, "model still at version"),
        last,
        "{still}"
    );

    // 11. the session stopped cleanly: both processes, no SIGKILL.
    assert!(stdout.contains("stopped simulator") && stdout.contains("stopped space"));
    assert!(!stdout.contains("SIGKILL"), "{stdout}");
}
