//! Exact mode at contact (issue #20, item 8) against testdata/collision/contact_pairs.json (see
//! the README there): primitives touching, 1e-9 m apart, 1e-9 m into each other, contained,
//! thin plates, 100 m and 1e-3 m scales, configurations rotated about two axes.
//!
//! Asserted on every case: the boolean right wherever |signed distance| > 1e-12 m (in the band
//! either answer is right — touching counts as contact); the signed distance within 1e-9 m
//! absolute (every case is at the 1e-3 m, 1 m or 100 m scale) or, where GJK hit its iteration
//! limit after certifying "apart", never above the truth (the lower bound is reported).
//!
//! Zero `Unknown` and no lower-bound-only distance are required. NOT YET MET: depths of
//! overlaps within 1e-9 m — counted, listed and held to a ratchet (`DEPTH_MISS_AT_MOST`); lower
//! it as the algorithm improves.
//!
//! Reference values from the support-function optimiser are lower bounds of the truth (any
//! direction's separating-plane bound is); where its five starts disagree by more than
//! 1e-10 m the value is compared one-sided (ours ≥ reference − 1e-9 m) and listed.

use robosim_collision::json::{pose_from_json, solid_from_json};
use robosim_collision::{Mode, PairResult, collide};
use serde_json::Value;

const BAND: f64 = 1e-12;
const DISTANCE_TOL: f64 = 1e-9;
/// Contact answers whose depth is missing or more than 1e-9 m off: overlap depths come from
/// parry's EPA (not certified) unless GJK's bracket already closed; 1e-9 m overlaps of curved
/// pairs come back as depth 0 (1.0000002e-9 m off) or none. 18 when written, 13 with the
/// ball closed form, 15 with the projections: box_cone_0_s100_g-1e-09 (both orders), Unknown
/// before, is now a certified contact whose EPA depth is 0.
/// 1 since the overlap's signed distance falls back on the maximised certified lower bound
/// (`exact/lower.rs`) where EPA disagrees with it: cylinder_cone_1_s100_g-1e-09 (a,b), whose
/// lower bound is still 1e-9 m below the truth.
const DEPTH_MISS_AT_MOST: usize = 1;

#[test]
fn exact_mode_at_contact_matches_the_references() {
    let text = include_str!("../../../testdata/collision/contact_pairs.json");
    let v: Value = serde_json::from_str(text).expect("contact_pairs.json parses");
    let cases = v["cases"].as_array().expect("cases");
    let mut unknown = Vec::new();
    let mut failures = Vec::new();
    let mut one_sided = Vec::new();
    let mut lower_only = Vec::new();
    let mut depth_miss = Vec::new();
    let mut worst: (f64, String) = (0.0, String::new());
    for c in cases {
        let name = c["name"].as_str().expect("name");
        let a = solid_from_json(&c["a"], "a", &[]).expect("shape a");
        let b = solid_from_json(&c["b"], "b", &[]).expect("shape b");
        let pa = pose_from_json(&c["pose_a"], "pose_a").expect("pose a");
        let pb = pose_from_json(&c["pose_b"], "pose_b").expect("pose b");
        let sd_ref = c["signed_distance"].as_f64().expect("sd");
        let spread = c["optimiser_spread"].as_f64().unwrap_or(0.0);
        for (r, order) in [
            (collide(&a, &pa, &b, &pb, Mode::Exact), "a,b"),
            (collide(&b, &pb, &a, &pa, Mode::Exact), "b,a"),
        ] {
            if let PairResult::Unknown { reason } = &r {
                unknown.push(format!("{name} ({order}): {reason}"));
                continue;
            }
            if sd_ref.abs() > BAND && r.intersects() != Some(sd_ref <= 0.0) {
                failures.push(format!(
                    "{name} ({order}): boolean wrong, {r:?} vs {sd_ref:e}"
                ));
            }
            let Some(sd) = r.signed_distance() else {
                if !r.is_clear() {
                    depth_miss.push(format!("{name} ({order}): no depth"));
                    continue;
                }
                failures.push(format!("{name} ({order}): no signed distance, {r:?}"));
                continue;
            };
            let err = sd - sd_ref;
            if spread > 1e-10 {
                one_sided.push(format!(
                    "{name}: ours − reference = {err:e} (spread {spread:e})"
                ));
                if err < -DISTANCE_TOL {
                    failures.push(format!(
                        "{name} ({order}): signed distance {sd:e} below the certified lower bound \
                         {sd_ref:e}"
                    ));
                }
                continue;
            }
            if err.abs() > worst.0 && err >= -DISTANCE_TOL {
                worst = (err.abs(), name.to_owned());
            }
            if err < -DISTANCE_TOL && r.is_clear() && sd_ref > 0.0 {
                lower_only.push(format!(
                    "{name} ({order}): {sd:e} vs {sd_ref:e} (Δ {err:e})"
                ));
            } else if err.abs() > DISTANCE_TOL && !r.is_clear() {
                depth_miss.push(format!(
                    "{name} ({order}): {sd:e} vs {sd_ref:e} (Δ {err:e})"
                ));
            } else if err.abs() > DISTANCE_TOL {
                failures.push(format!(
                    "{name} ({order}): signed distance {sd:e} vs reference {sd_ref:e} (Δ {err:e})"
                ));
            }
        }
    }
    eprintln!(
        "contact references: {} cases × 2 orders, worst |Δ signed distance| = {:e} m ({}), {} unknown, \
         {} compared one-sided:\n  {}",
        cases.len(),
        worst.0,
        worst.1,
        unknown.len(),
        one_sided.len(),
        one_sided.join("\n  ")
    );
    eprintln!(
        "unknown answers:\n  {}\nclear with a lower-bound distance:\n  {}\ndepth missing or off:\n  {}",
        unknown.join("\n  "),
        lower_only.join("\n  "),
        depth_miss.join("\n  ")
    );
    assert!(
        depth_miss.len() <= DEPTH_MISS_AT_MOST,
        "{} depth misses",
        depth_miss.len()
    );
    assert!(
        failures.is_empty(),
        "{} failures:\n{}",
        failures.len(),
        failures.join("\n")
    );
    // Unknown answers (of 1,120: each case in both orders): 89 when this test was written, 50
    // since a ball against a box, cylinder or cone is closed form (`exact/sphere.rs`), 24 with
    // alternating exact projections (`exact/projection.rs`), 18 with the lower bound maximised
    // over directions (`exact/lower.rs`), none since rims are searched by angle and hulls are
    // projected exactly: the ratchet became a requirement.
    assert!(unknown.is_empty(), "{} unknown", unknown.len());
    // Clear answers whose distance is GJK's certified lower bound, more than 1e-9 m below the
    // reference: 10 when written, 1 with the ball closed form, none since the lower bound is
    // maximised over directions (`exact/lower.rs`), so the ratchet became a requirement.
    assert!(
        lower_only.is_empty(),
        "{} lower-bound distances",
        lower_only.len()
    );
    assert!(cases.len() >= 500, "only {} cases", cases.len());
}
