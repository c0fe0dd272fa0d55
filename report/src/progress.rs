//! Progress of long work (reports, benches, studies): an `indicatif` bar on standard error.
//!
//! A bar draws only when standard error is a terminal (indicatif hides it otherwise, so logs,
//! pipes and tests see nothing) and not at all after [`set_quiet`] (`robosim -q`). Bars never
//! write to standard output, so the results a command prints stay clean.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::sync::atomic::{AtomicBool, Ordering};

static QUIET: AtomicBool = AtomicBool::new(false);

/// `robosim -q`: no bars from now on.
pub fn set_quiet(quiet: bool) {
    QUIET.store(quiet, Ordering::Relaxed);
}

/// A bar of `len` units of work named `what` (e.g. "report ik", "IK cases").
pub fn bar(len: u64, what: &str) -> ProgressBar {
    let target = if QUIET.load(Ordering::Relaxed) {
        ProgressDrawTarget::hidden()
    } else {
        ProgressDrawTarget::stderr()
    };
    let pb = ProgressBar::with_draw_target(Some(len), target);
    if let Ok(style) = ProgressStyle::with_template("{prefix:>16} {work} {msg} [{elapsed}]") {
        pb.set_style(style.with_key(
            "work",
            |state: &indicatif::ProgressState, w: &mut dyn std::fmt::Write| {
                let _ = w.write_str(&work_text(state.pos(), state.len()));
                if state.len().is_some_and(|l| l > 0) {
                    let _ = write!(w, " (ETA {})", indicatif::HumanDuration(state.eta()));
                }
            },
        ));
    }
    pb.set_prefix(what.to_owned());
    pb
}

/// Width of the bar, characters between the brackets.
const BAR_WIDTH: usize = 30;

/// The bar and count of `pos` units done out of `len`: `[=====>    ] 5/10`. A length not known
/// yet (or nothing to do: `0`) draws an empty bar and `5/?` — indicatif would draw 0/0 as a full
/// bar, as if the work were done before it started.
fn work_text(pos: u64, len: Option<u64>) -> String {
    match len {
        Some(len) if len > 0 => {
            let filled = ((pos.min(len) as f64 / len as f64) * BAR_WIDTH as f64) as usize;
            let head = usize::from(filled < BAR_WIDTH && pos > 0);
            format!(
                "[{}{}{}] {pos}/{len}",
                "=".repeat(filled),
                ">".repeat(head),
                " ".repeat(BAR_WIDTH - filled - head)
            )
        }
        _ => format!("[{}] {pos}/?", " ".repeat(BAR_WIDTH)),
    }
}

/// A spinner for work of unknown length (a whole report or bench): the elapsed time, redrawn
/// by indicatif's ticker thread; clear it with `finish_and_clear`.
pub fn spinner(what: &str) -> ProgressBar {
    let pb = bar(0, what);
    pb.set_length(0);
    if let Ok(style) = ProgressStyle::with_template("{prefix:>16} {spinner} {elapsed} {msg}") {
        pb.set_style(style);
    }
    pb.enable_steady_tick(std::time::Duration::from_millis(200));
    pb
}

/// Runs `f` on each item with a bar of `items.len()` named `what`, the item's label as the
/// bar's message; the bar is cleared at the end.
pub fn each<T, R>(
    items: impl IntoIterator<Item = T>,
    what: &str,
    label: impl Fn(&T) -> String,
    mut f: impl FnMut(T) -> R,
) -> Vec<R> {
    let items: Vec<T> = items.into_iter().collect();
    let pb = bar(items.len() as u64, what);
    let out = items
        .into_iter()
        .map(|item| {
            pb.set_message(label(&item));
            let r = f(item);
            pb.inc(1);
            r
        })
        .collect();
    pb.finish_and_clear();
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Issue 39 item 8: a bar whose length is not known yet, or zero, is drawn empty (`0/0`
    /// used to be a full bar); a known length fills in proportion.
    #[test]
    fn the_bar_is_empty_until_its_length_is_known_and_fills_in_proportion() {
        let filled = |t: &str| t.chars().filter(|&c| c == '=').count();
        for (pos, len) in [(0, Some(0)), (0, None), (7, Some(0))] {
            let t = work_text(pos, len);
            assert_eq!(filled(&t), 0, "{pos}/{len:?}: {t}");
            assert!(t.ends_with(&format!("{pos}/?")), "{t}");
        }
        assert_eq!(filled(&work_text(0, Some(10))), 0);
        assert_eq!(filled(&work_text(5, Some(10))), BAR_WIDTH / 2);
        let done = work_text(10, Some(10));
        assert_eq!(filled(&done), BAR_WIDTH, "{done}");
        assert!(done.ends_with("10/10"), "{done}");
        assert_eq!(work_text(3, Some(10)).len(), work_text(0, Some(10)).len());
    }

    /// The helper visits every item once, in order, and returns their results in order.
    #[test]
    fn each_maps_every_item_in_order() {
        set_quiet(true);
        let seen = each(vec![3, 1, 2], "t", |x| x.to_string(), |x| x * 10);
        assert_eq!(seen, vec![30, 10, 20]);
    }
}
