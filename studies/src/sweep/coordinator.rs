//! The coordinator: hands jobs to workers one at a time (a slow worker gets fewer), gathers
//! their results by job index, and redoes the job of a worker that died.
//!
//! A worker is dead when its output ends (exit, crash, `kill -9`), when it stops being alive
//! ([`WorkerLink::is_alive`], checked every tick), when it answers for a job it was not given,
//! or when a job runs over the timeout. Its job in flight goes back to the front of the queue
//! and is redone (on whichever worker is free first) until it has been tried `max_attempts`
//! times; then it is a failed job ("the worker died … times running this job"). The slot is
//! started again; a slot whose workers die `max_attempts` times in a row without a job in
//! flight (one that cannot start) is given up. Every death is one log line; the results do not
//! depend on who ran what.
//!
//! A slot whose launcher is waiting for its host ([`Launcher::waiting`]: the host's link lapsed)
//! is neither started nor given up: it takes jobs again once its host is back. While other
//! workers run it may wait as long as the sweep lasts; when every slot left waits, the sweep
//! fails after [`Options::host_wait`] without a host coming back.

use super::SweepError;
use super::protocol::{self, Outcome};
use super::spec::Job;
use super::transport::{Event, EventSink, Launcher, WorkerLink};
use std::collections::VecDeque;
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// How the coordinator deals with failure.
#[derive(Debug, Clone)]
pub struct Options {
    /// Tries per job before it is reported failed (≥ 1).
    pub max_attempts: u32,
    /// A job running longer than this kills its worker (and counts as a death). None: no limit.
    pub job_timeout: Option<Duration>,
    /// How long every worker left may wait for its host to come back before the sweep fails.
    pub host_wait: Duration,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            max_attempts: 3,
            job_timeout: None,
            host_wait: Duration::from_secs(15),
        }
    }
}

/// What happened in a sweep besides the results.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Stats {
    /// Workers started, including restarts.
    pub started: usize,
    /// Workers that died.
    pub deaths: usize,
    /// Jobs sent again after their worker died.
    pub redone: usize,
    /// Jobs each slot completed.
    pub per_slot: Vec<usize>,
}

struct Slot {
    launcher: Box<dyn Launcher>,
    link: Option<Box<dyn WorkerLink>>,
    generation: u64,
    in_flight: Option<(usize, Instant)>,
    /// Deaths without a job in flight since the last result.
    idle_deaths: u32,
    retired: bool,
    /// What its launcher said it waits for (logged once), while it does.
    waiting: Option<String>,
}

/// The jobs' book: what is queued, tried, answered and still to come, and what the workers
/// did. A worker's death is booked here ([`Ledger::died`]).
struct Ledger<'j> {
    jobs: &'j [Job],
    max_attempts: u32,
    queue: VecDeque<usize>,
    attempts: Vec<u32>,
    results: Vec<Option<Outcome>>,
    remaining: usize,
    stats: Stats,
    /// Why the last worker died (said when every slot is given up).
    last_death: String,
}

impl Ledger<'_> {
    /// Slot `s`'s worker is gone (`why`): its job back to the front of the queue (or failed
    /// after `max_attempts` tries), the death logged; the slot is given up after
    /// `max_attempts` deaths in a row without a job.
    fn died(&mut self, s: usize, slot: &mut Slot, why: &str, log: &mut dyn FnMut(String)) {
        let Some(mut link) = slot.link.take() else {
            return;
        };
        let who = link.describe();
        let how = link.kill();
        self.stats.deaths += 1;
        let mut line = format!("sweep: worker {s} ({who}) died: {why} ({how})");
        self.last_death = format!("{why} ({how})");
        match slot.in_flight.take() {
            Some((k, _)) => {
                slot.idle_deaths = 0;
                self.attempts[k] += 1;
                let (index, tried) = (self.jobs[k].index, self.attempts[k]);
                if tried >= self.max_attempts {
                    line += &format!("; job {index} failed: tried {tried} times");
                    self.results[k] = Some(Err(format!(
                        "the worker died {tried} times running this job (last: {why}, {how})"
                    )));
                    self.remaining -= 1;
                } else {
                    line += &format!(
                        "; job {index} is redone (attempt {} of {})",
                        tried + 1,
                        self.max_attempts
                    );
                    self.stats.redone += 1;
                    self.queue.push_front(k);
                }
            }
            None => slot.idle_deaths += 1,
        }
        log(line);
        if slot.idle_deaths >= self.max_attempts {
            log(format!(
                "sweep: worker {s} given up: it died {} times without running a job",
                slot.idle_deaths
            ));
            slot.retired = true;
        }
    }
}

/// Runs `jobs` of `study` on the workers `launchers` start (one worker per launcher), and
/// returns each job's outcome by position in `jobs`. `log` gets one line per event worth
/// telling (a worker started, died, a job redone); `done` is called after every result.
pub fn run(
    study: &str,
    jobs: &[Job],
    launchers: Vec<Box<dyn Launcher>>,
    opts: &Options,
    log: &mut dyn FnMut(String),
    done: &mut dyn FnMut(usize),
) -> Result<(Vec<Outcome>, Stats), SweepError> {
    if launchers.is_empty() {
        return Err(SweepError::NoWorkers);
    }
    let max_attempts = opts.max_attempts.max(1);
    let (tx, rx) = mpsc::channel::<Event>();
    let mut slots: Vec<Slot> = launchers
        .into_iter()
        .map(|launcher| Slot {
            launcher,
            link: None,
            generation: 0,
            in_flight: None,
            idle_deaths: 0,
            retired: false,
            waiting: None,
        })
        .collect();
    let by_index: std::collections::HashMap<usize, usize> =
        jobs.iter().enumerate().map(|(k, j)| (j.index, k)).collect();
    let mut book = Ledger {
        jobs,
        max_attempts,
        queue: (0..jobs.len()).collect(),
        attempts: vec![0u32; jobs.len()],
        results: vec![None; jobs.len()],
        remaining: jobs.len(),
        stats: Stats {
            per_slot: vec![0; slots.len()],
            ..Stats::default()
        },
        last_death: String::new(),
    };
    for (s, slot) in slots.iter_mut().enumerate() {
        if !start(&tx, s, slot, &mut book.stats, log, &mut book.last_death) {
            slot.retired = true;
        }
    }

    let tick = Duration::from_millis(200);
    // Since when every slot left has been waiting for its host (none running).
    let mut stalled: Option<Instant> = None;
    while book.remaining > 0 {
        // restart dead slots, then give every idle worker a job
        for (s, slot) in slots.iter_mut().enumerate() {
            if slot.retired || book.queue.is_empty() {
                continue;
            }
            if !ready(&tx, s, slot, &mut book, log) {
                continue;
            }
            if slot.in_flight.is_some() {
                continue;
            }
            let Some(k) = book.queue.pop_front() else {
                break;
            };
            hand_out(study, s, slot, k, &mut book, log);
        }
        check_workers_left(&mut slots, &book, &mut stalled, opts)?;
        let ev = match rx.recv_timeout(tick) {
            Ok(ev) => Some(ev),
            Err(mpsc::RecvTimeoutError::Timeout) => None,
            // the coordinator holds a sender: the channel cannot disconnect
            Err(mpsc::RecvTimeoutError::Disconnected) => None,
        };
        if let Some(ev) = ev
            && !take_event(ev, &mut slots, &by_index, &mut book, log, done)
        {
            // an earlier worker's event: the next round (as before the split, no reaping)
            continue;
        }
        reap(&mut slots, &mut book, opts, log);
    }
    for slot in &mut slots {
        if let Some(mut link) = slot.link.take() {
            link.finish(Duration::from_secs(2));
        }
    }
    let outcomes = book
        .results
        .into_iter()
        .map(|r| r.unwrap_or_else(|| Err("no result (internal: job lost)".into())))
        .collect();
    Ok((outcomes, book.stats))
}

/// Starts slot `s`'s worker (its events sent on `tx`); false when it could not (why in
/// `last`).
fn start(
    tx: &mpsc::Sender<Event>,
    s: usize,
    slot: &mut Slot,
    stats: &mut Stats,
    log: &mut dyn FnMut(String),
    last: &mut String,
) -> bool {
    slot.generation += 1;
    match slot
        .launcher
        .launch(EventSink::new(tx.clone(), s, slot.generation))
    {
        Ok(link) => {
            log(format!(
                "sweep: worker {s} started: {} {}",
                slot.launcher.describe(),
                link.describe()
            ));
            slot.link = Some(link);
            stats.started += 1;
            true
        }
        Err(e) => {
            log(format!(
                "sweep: worker {s} ({}) could not start: {e}",
                slot.launcher.describe()
            ));
            *last = e;
            false
        }
    }
}

/// Whether slot `s` has a worker to give a job: a slot without one waits while its launcher
/// waits for its host (said once), else its worker is started again; a slot that cannot be
/// started `max_attempts` times in a row is given up.
fn ready(
    tx: &mpsc::Sender<Event>,
    s: usize,
    slot: &mut Slot,
    book: &mut Ledger,
    log: &mut dyn FnMut(String),
) -> bool {
    if slot.link.is_some() {
        return true;
    }
    match slot.launcher.waiting() {
        Some(why) => {
            if slot.waiting.is_none() {
                log(format!(
                    "sweep: worker {s} ({}) waits: {why}",
                    slot.launcher.describe()
                ));
                book.last_death = why.clone();
                slot.waiting = Some(why);
            }
            return false;
        }
        None => {
            if slot.waiting.take().is_some() {
                log(format!(
                    "sweep: worker {s} ({}) can start again",
                    slot.launcher.describe()
                ));
                slot.idle_deaths = 0;
            }
        }
    }
    if !start(tx, s, slot, &mut book.stats, log, &mut book.last_death) {
        slot.idle_deaths += 1;
        if slot.idle_deaths >= book.max_attempts {
            log(format!(
                "sweep: worker {s} given up: it could not be started {} times in a row",
                slot.idle_deaths
            ));
            slot.retired = true;
        }
        return false;
    }
    true
}

/// Sends job `k` to slot `s`'s worker; a job that never reached it goes back to the front of
/// the queue (not an attempt) and the worker is dead.
fn hand_out(
    study: &str,
    s: usize,
    slot: &mut Slot,
    k: usize,
    book: &mut Ledger,
    log: &mut dyn FnMut(String),
) {
    let line = protocol::job_line(study, &book.jobs[k]);
    let sent = match slot.link.as_mut() {
        Some(link) => link.send(&line),
        None => Err("not started".into()),
    };
    match sent {
        Ok(()) => slot.in_flight = Some((k, Instant::now())),
        Err(e) => {
            // never reached the worker: not an attempt
            book.queue.push_front(k);
            let index = book.jobs[k].index;
            book.died(s, slot, &format!("sending job {index}: {e}"), log);
        }
    }
}

/// Fails the sweep when every slot is given up, or when every slot left has waited for its
/// host longer than [`Options::host_wait`] (`stalled`: since when they all wait).
fn check_workers_left(
    slots: &mut [Slot],
    book: &Ledger,
    stalled: &mut Option<Instant>,
    opts: &Options,
) -> Result<(), SweepError> {
    if slots.iter().all(|s| s.retired) {
        return Err(SweepError::NoWorkersLeft {
            remaining: book.remaining,
            last: book.last_death.clone(),
        });
    }
    let all_wait = slots
        .iter()
        .all(|s| s.retired || (s.link.is_none() && s.waiting.is_some()));
    match (all_wait, *stalled) {
        (false, _) => *stalled = None,
        (true, None) => *stalled = Some(Instant::now()),
        (true, Some(t0)) if t0.elapsed() > opts.host_wait => {
            for slot in slots.iter_mut() {
                slot.retired = true;
            }
            return Err(SweepError::NoWorkersLeft {
                remaining: book.remaining,
                last: format!(
                    "{}; no host came back within {:.0} s",
                    book.last_death,
                    opts.host_wait.as_secs_f64()
                ),
            });
        }
        (true, Some(_)) => {}
    }
    Ok(())
}

/// A worker's event: its answer booked (or, for a job it was not given or a line that does
/// not parse, its death), or the end of its output (its death). Events of an earlier worker
/// of the slot (or of no slot) are ignored: false.
fn take_event(
    ev: Event,
    slots: &mut [Slot],
    by_index: &std::collections::HashMap<usize, usize>,
    book: &mut Ledger,
    log: &mut dyn FnMut(String),
    done: &mut dyn FnMut(usize),
) -> bool {
    match ev {
        Event::Line {
            slot: s,
            generation,
            line,
        } => {
            let Some(slot) = slots.get_mut(s) else {
                return false;
            };
            if generation != slot.generation || slot.link.is_none() {
                return false;
            }
            let parsed = protocol::parse_result(&line);
            let expected = slot.in_flight.map(|(k, _)| book.jobs[k].index);
            match parsed {
                Ok((index, outcome)) if Some(index) == expected => {
                    let k = by_index[&index];
                    slot.in_flight = None;
                    slot.idle_deaths = 0;
                    if book.results[k].is_none() {
                        book.results[k] = Some(outcome);
                        book.remaining -= 1;
                        book.stats.per_slot[s] += 1;
                        done(book.remaining);
                    }
                }
                other => {
                    let why = match other {
                        Ok((index, _)) => format!(
                            "answered for job {index} while running {}",
                            expected.map_or("none".into(), |i| i.to_string())
                        ),
                        Err(e) => e,
                    };
                    book.died(s, slot, &why, log);
                }
            }
        }
        Event::Closed {
            slot: s,
            generation,
        } => {
            let Some(slot) = slots.get_mut(s) else {
                return false;
            };
            if generation != slot.generation || slot.link.is_none() {
                return false;
            }
            book.died(s, slot, "its output ended", log);
        }
    }
    true
}

/// Timeouts, and idle workers that exited (one with a job in flight is reported by the end
/// of its output, after its last line): their deaths booked.
fn reap(slots: &mut [Slot], book: &mut Ledger, opts: &Options, log: &mut dyn FnMut(String)) {
    for (s, slot) in slots.iter_mut().enumerate() {
        let Some(link) = slot.link.as_mut() else {
            continue;
        };
        let why = match slot.in_flight {
            Some((k, t0)) if opts.job_timeout.is_some_and(|limit| t0.elapsed() > limit) => {
                format!(
                    "job {} ran over the {:.1} s timeout",
                    book.jobs[k].index,
                    opts.job_timeout.map_or(0.0, |d| d.as_secs_f64())
                )
            }
            Some(_) => continue,
            None if !link.is_alive() => "it is no longer alive".to_owned(),
            None => continue,
        };
        book.died(s, slot, &why, log);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sweep::spec::Value;
    use std::sync::mpsc::Sender;

    /// Workers on threads: each answers job i with [i, 2i], and "dies" (its output ends
    /// without an answer) on job `die_on`; `start` false: it cannot be started.
    struct Threads {
        die_on: Option<usize>,
        start: bool,
    }

    struct ThreadLink {
        jobs: Option<Sender<String>>,
        alive: std::sync::Arc<std::sync::atomic::AtomicBool>,
    }

    impl Launcher for Threads {
        fn describe(&self) -> String {
            "thread".into()
        }
        fn launch(&mut self, sink: EventSink) -> Result<Box<dyn WorkerLink>, String> {
            if !self.start {
                return Err("no threads today".into());
            }
            let (tx, rx) = mpsc::channel::<String>();
            let alive = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(true));
            let flag = alive.clone();
            let die_on = self.die_on;
            std::thread::spawn(move || {
                for line in rx {
                    let (_, job) = protocol::parse_job(&line).expect("a job line");
                    if Some(job.index) == die_on {
                        break;
                    }
                    let i = job.index as f64;
                    sink.line(protocol::result_line(job.index, &Ok(vec![i, 2.0 * i])));
                }
                flag.store(false, std::sync::atomic::Ordering::SeqCst);
                sink.closed();
            });
            Ok(Box::new(ThreadLink {
                jobs: Some(tx),
                alive,
            }))
        }
    }

    impl WorkerLink for ThreadLink {
        fn describe(&self) -> String {
            "thread".into()
        }
        fn send(&mut self, line: &str) -> Result<(), String> {
            self.jobs
                .as_ref()
                .ok_or("closed")?
                .send(line.to_owned())
                .map_err(|e| e.to_string())
        }
        fn is_alive(&mut self) -> bool {
            self.alive.load(std::sync::atomic::Ordering::SeqCst)
        }
        fn kill(&mut self) -> String {
            self.jobs = None;
            "stopped".into()
        }
        fn finish(&mut self, _grace: Duration) {
            self.jobs = None;
        }
    }

    fn jobs(n: usize) -> Vec<Job> {
        (0..n)
            .map(|index| Job {
                index,
                params: vec![("x".into(), Value::Num(index as f64))],
            })
            .collect()
    }

    fn launchers(n: usize, die_on: Option<usize>, start: bool) -> Vec<Box<dyn Launcher>> {
        (0..n)
            .map(|_| Box::new(Threads { die_on, start }) as Box<dyn Launcher>)
            .collect()
    }

    #[test]
    fn every_job_answered_once_in_job_order() {
        let js = jobs(25);
        let (out, stats) = run(
            "t",
            &js,
            launchers(3, None, true),
            &Options::default(),
            &mut |_| {},
            &mut |_| {},
        )
        .expect("sweep");
        for (i, o) in out.iter().enumerate() {
            assert_eq!(o, &Ok(vec![i as f64, 2.0 * i as f64]));
        }
        assert_eq!(stats.per_slot.iter().sum::<usize>(), 25);
        assert_eq!((stats.started, stats.deaths, stats.redone), (3, 0, 0));
    }

    #[test]
    fn a_job_that_ends_every_worker_fails_after_its_attempts_and_alone() {
        let js = jobs(6);
        let mut log = Vec::new();
        let (out, stats) = run(
            "t",
            &js,
            launchers(2, Some(4), true),
            &Options {
                max_attempts: 3,
                job_timeout: None,
                ..Options::default()
            },
            &mut |l| log.push(l),
            &mut |_| {},
        )
        .expect("sweep");
        for (i, o) in out.iter().enumerate() {
            if i == 4 {
                let e = o.as_ref().expect_err("job 4 fails");
                assert!(
                    e.starts_with("the worker died 3 times running this job"),
                    "{e}"
                );
            } else {
                assert_eq!(o, &Ok(vec![i as f64, 2.0 * i as f64]));
            }
        }
        assert_eq!((stats.deaths, stats.redone), (3, 2), "{log:#?}");
        assert!(
            log.iter()
                .any(|l| l.contains("job 4 is redone (attempt 2 of 3)"))
        );
        assert!(
            log.iter()
                .any(|l| l.contains("job 4 failed: tried 3 times"))
        );
    }

    #[test]
    fn workers_that_cannot_start_end_the_sweep_with_an_error() {
        let e = run(
            "t",
            &jobs(2),
            launchers(2, None, false),
            &Options::default(),
            &mut |_| {},
            &mut |_| {},
        )
        .expect_err("no workers");
        assert!(
            e.to_string()
                .contains("no worker left with 2 jobs to run (last: no threads today)"),
            "{e}"
        );
        assert!(matches!(
            run(
                "t",
                &jobs(1),
                Vec::new(),
                &Options::default(),
                &mut |_| {},
                &mut |_| {}
            ),
            Err(SweepError::NoWorkers)
        ));
    }

    /// Workers on a "host" that goes away while running job `away_on` the first time (its
    /// worker's output ends, as when a link lapses) and comes back after `back_after` (never
    /// when `None`).
    struct Away {
        here: std::sync::Arc<std::sync::atomic::AtomicBool>,
        gone_once: std::sync::Arc<std::sync::atomic::AtomicBool>,
        away_on: usize,
        back_after: Option<Duration>,
    }

    impl Launcher for Away {
        fn describe(&self) -> String {
            "away".into()
        }
        fn waiting(&self) -> Option<String> {
            (!self.here.load(std::sync::atomic::Ordering::SeqCst)).then(|| "host away".into())
        }
        fn launch(&mut self, sink: EventSink) -> Result<Box<dyn WorkerLink>, String> {
            use std::sync::atomic::Ordering::SeqCst;
            if !self.here.load(SeqCst) {
                return Err("launched while its host is away".into());
            }
            let (tx, rx) = mpsc::channel::<String>();
            let alive = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(true));
            let (flag, here, gone_once) =
                (alive.clone(), self.here.clone(), self.gone_once.clone());
            let (away_on, back_after) = (self.away_on, self.back_after);
            std::thread::spawn(move || {
                for line in rx {
                    let (_, job) = protocol::parse_job(&line).expect("a job line");
                    if job.index == away_on && !gone_once.swap(true, SeqCst) {
                        here.store(false, SeqCst);
                        if let Some(d) = back_after {
                            let h = here.clone();
                            std::thread::spawn(move || {
                                std::thread::sleep(d);
                                h.store(true, SeqCst);
                            });
                        }
                        break;
                    }
                    let i = job.index as f64;
                    sink.line(protocol::result_line(job.index, &Ok(vec![i, 2.0 * i])));
                }
                flag.store(false, SeqCst);
                sink.closed();
            });
            Ok(Box::new(ThreadLink {
                jobs: Some(tx),
                alive,
            }))
        }
    }

    fn away(back_after: Option<Duration>) -> Vec<Box<dyn Launcher>> {
        vec![Box::new(Away {
            here: std::sync::Arc::new(std::sync::atomic::AtomicBool::new(true)),
            gone_once: Default::default(),
            away_on: 3,
            back_after,
        })]
    }

    #[test]
    fn a_worker_whose_host_went_away_waits_and_is_used_again_when_it_is_back() {
        let js = jobs(8);
        let mut log = Vec::new();
        // max_attempts 2: a coordinator that launched while the host is away would give the
        // slot up after two failed starts, and the sweep would fail
        let (out, stats) = run(
            "t",
            &js,
            away(Some(Duration::from_millis(300))),
            &Options {
                max_attempts: 2,
                ..Options::default()
            },
            &mut |l| log.push(l),
            &mut |_| {},
        )
        .expect("sweep");
        for (i, o) in out.iter().enumerate() {
            assert_eq!(o, &Ok(vec![i as f64, 2.0 * i as f64]), "{log:#?}");
        }
        assert_eq!(
            (stats.started, stats.deaths, stats.redone),
            (2, 1, 1),
            "{log:#?}"
        );
        let at = |needle: &str| log.iter().position(|l| l.contains(needle));
        let (Some(died), Some(waits), Some(again)) = (
            at("worker 0 (thread) died: its output ended"),
            at("worker 0 (away) waits: host away"),
            at("worker 0 (away) can start again"),
        ) else {
            panic!("{log:#?}");
        };
        assert!(died < waits && waits < again, "{log:#?}");
        assert_eq!(
            log.iter().filter(|l| l.contains("waits")).count(),
            1,
            "{log:#?}"
        );
    }

    #[test]
    fn a_sweep_whose_every_host_stays_away_fails_after_the_host_wait() {
        let t0 = Instant::now();
        let e = run(
            "t",
            &jobs(8),
            away(None),
            &Options {
                host_wait: Duration::from_secs(1),
                ..Options::default()
            },
            &mut |_| {},
            &mut |_| {},
        )
        .expect_err("no host");
        assert!(t0.elapsed() >= Duration::from_secs(1));
        assert!(
            e.to_string().contains(
                "no worker left with 5 jobs to run (last: host away; no host came back within 1 s)"
            ),
            "{e}"
        );
    }
}
