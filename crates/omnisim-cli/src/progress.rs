//! Progress of a long run on standard error, shared by `render` and `dataset`: a bar with the
//! rate and ETA on a terminal; elsewhere (a log, CI) a plain line every 10 seconds with the
//! rate, and a last one at the end of a run that printed any, so that a long run is never silent.

use std::io::IsTerminal;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressStyle};

/// How often a plain line is printed, unless `OMNISIM_PROGRESS_SECONDS` says otherwise (a
/// CI log may want fewer).
const EVERY: Duration = Duration::from_secs(10);

/// The interval between plain lines: `OMNISIM_PROGRESS_SECONDS` where it is a number of seconds
/// (beyond what a `Duration` holds: never), else [`EVERY`] with a warning, once a process.
fn interval() -> Duration {
    let Some(text) = std::env::var_os("OMNISIM_PROGRESS_SECONDS") else {
        return EVERY;
    };
    let seconds = text.to_str().and_then(|t| t.trim().parse::<f64>().ok());
    match seconds {
        Some(seconds) if seconds >= 0.0 => Duration::try_from_secs_f64(seconds).unwrap_or(Duration::MAX),
        _ => {
            static WARNED: std::sync::Once = std::sync::Once::new();
            WARNED.call_once(|| {
                let _ = crate::streams::stderr(format_args!(
                    "warning: OMNISIM_PROGRESS_SECONDS={} is not a number of seconds (0 or more); progress lines come \
                     every {} s",
                    text.to_string_lossy(),
                    EVERY.as_secs()
                ));
            });
            EVERY
        }
    }
}

/// Whether standard error is a terminal that draws a bar: not where `TERM=dumb`, where the bar
/// draws nothing and plain lines keep a long run from being silent.
fn draws_bars() -> bool {
    std::io::stderr().is_terminal() && std::env::var_os("TERM").is_none_or(|term| term != "dumb")
}

pub(crate) struct Progress {
    /// What is counted, plural ("poses", "frames").
    unit: &'static str,
    /// Whether stderr is a terminal (bar) or not (plain lines); asked once.
    terminal: bool,
    /// How often a plain line is printed.
    every: Duration,
    bar: Option<ProgressBar>,
    started: Instant,
    /// When the last plain line was printed.
    last_line: Option<Instant>,
    /// When the last item was heard of.
    last_step: Option<Instant>,
    /// Items this run finished.
    here: usize,
    /// Items an earlier run finished: they take no time, so they leave the bar and the rate.
    earlier: usize,
}

impl Progress {
    pub(crate) fn new(unit: &'static str) -> Self {
        Self {
            unit,
            terminal: draws_bars(),
            every: interval(),
            bar: None,
            started: Instant::now(),
            last_line: None,
            last_step: None,
            here: 0,
            earlier: 0,
        }
    }

    /// Hears that item `done` of `total` (both counting items an earlier run finished) is
    /// finished, by an `earlier` run or this one; `note` says where the run is.
    pub(crate) fn step(&mut self, done: usize, total: usize, earlier: bool, note: &str) -> anyhow::Result<()> {
        let now = Instant::now();
        self.last_step = Some(now);
        if earlier {
            self.earlier += 1;
        } else {
            self.here += 1;
        }
        if !self.terminal {
            // Measured back from now: a huge interval (OMNISIM_PROGRESS_SECONDS) cannot overflow.
            let due = now.duration_since(self.last_line.unwrap_or(self.started)) >= self.every;
            if due || (done == total && self.last_line.is_some()) {
                let rate = self.here as f64 / (now - self.started).as_secs_f64().max(1e-9);
                let note = if note.is_empty() {
                    String::new()
                } else {
                    format!(" ({note})")
                };
                crate::streams::stderr(format_args!("{done}/{total} {}, {rate:.1}/s{note}", self.unit))?;
                self.last_line = Some(now);
            }
            return Ok(());
        }
        let unit = self.unit;
        let bar = self.bar.get_or_insert_with(|| {
            ProgressBar::new(total as u64).with_style(
                ProgressStyle::with_template(&format!(
                    "{{bar:40}} {{pos}}/{{len}} {unit}, {{per_sec}}, {{elapsed}} elapsed, ETA {{eta}} {{msg}}"
                ))
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
            )
        });
        if earlier {
            bar.set_length(bar.length().unwrap_or(0).saturating_sub(1));
        } else {
            bar.inc(1);
        }
        match (self.earlier, note.is_empty()) {
            (0, true) => {}
            (0, false) => bar.set_message(format!("({note})")),
            (n, _) => bar.set_message(format!("({note}; {n} done by an earlier run)")),
        }
        Ok(())
    }

    /// When the last item was heard of.
    pub(crate) fn last_step(&self) -> Option<Instant> {
        self.last_step
    }

    pub(crate) fn finish(&self) {
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
    }
}
