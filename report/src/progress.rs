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
    if let Ok(style) = ProgressStyle::with_template(
        "{prefix:>16} [{bar:30}] {pos}/{len} {msg} ({elapsed}, ETA {eta})",
    ) {
        pb.set_style(style.progress_chars("=> "));
    }
    pb.set_prefix(what.to_owned());
    pb
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

    /// The helper visits every item once, in order, and returns their results in order.
    #[test]
    fn each_maps_every_item_in_order() {
        set_quiet(true);
        let seen = each(vec![3, 1, 2], "t", |x| x.to_string(), |x| x * 10);
        assert_eq!(seen, vec![30, 10, 20]);
    }
}
