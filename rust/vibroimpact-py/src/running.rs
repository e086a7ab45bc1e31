//! A run in progress (`_core.start`, begun by the first `wait`): the core runs on a worker
//! thread (a short run: on the calling thread, inside that `wait`) and hands its recorded
//! rows over a bounded channel (two blocks: when the Python side falls behind, the core
//! waits, so memory stays bounded), its simulated time through an atomic and its solver
//! events through a bounded buffer. The Python side (`vibroimpact.simulate`) polls: `wait`
//! (GIL released), `take_rows`, `take_events`, `time`, then `finish`. No Python runs inside
//! the time loop.

use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::mpsc::{sync_channel, Receiver, RecvTimeoutError, SyncSender};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use vibroimpact_core::simulate::{simulate_streamed, BalanceError, Event, Rows, RunOutput, Sink};
use vibroimpact_core::SimError;

use crate::{convert, output_to_dict, rows_to_dict, to_py_err};

/// Steps × DOFs² × gaps below which a run is short enough to go without a worker thread.
const INLINE_WORK: f64 = 1e5;
/// Row blocks the channel holds before the core waits for the Python side.
const BLOCKS_IN_FLIGHT: usize = 2;
/// Events held between two polls; more are counted, not kept.
const MAX_EVENTS: usize = 10_000;

/// What the run's thread publishes besides the rows.
#[derive(Default)]
struct Shared {
    /// Simulated time reached (f64 bits), s.
    time: AtomicU64,
    events: Mutex<Vec<Event>>,
    dropped_events: AtomicUsize,
}

struct ChannelSink {
    shared: Arc<Shared>,
    /// Dropped when the run ends: the receiver then sees the channel disconnected.
    tx: Option<SyncSender<Rows>>,
    chunk: Option<usize>,
    events: bool,
}

impl Sink for ChannelSink {
    fn chunk_rows(&self) -> Option<usize> {
        self.chunk
    }
    fn rows(&mut self, rows: Rows) {
        // a receiver gone (the Python side failed and asked the run to stop): drop the rows
        if self.tx.as_ref().is_some_and(|tx| tx.send(rows).is_err()) {
            self.tx = None;
        }
    }
    fn wants_events(&self) -> bool {
        self.events
    }
    fn event(&mut self, event: Event) {
        let mut events = self.shared.events.lock().unwrap_or_else(|e| e.into_inner());
        if events.len() < MAX_EVENTS {
            events.push(event);
        } else {
            self.shared.dropped_events.fetch_add(1, Ordering::Relaxed);
        }
    }
    fn progress(&mut self, t: f64) {
        self.shared.time.store(t.to_bits(), Ordering::Relaxed);
    }
}

enum Worker {
    /// Converted, not begun: the first `wait` runs it there (a short run) or on a thread.
    Ready(Box<(convert::Job, ChannelSink)>),
    Thread(JoinHandle<Result<RunOutput, SimError>>),
    Done(Box<Result<RunOutput, SimError>>),
    Taken,
}

/// A run prepared by `start`.
#[pyclass(module = "vibroimpact._core")]
pub(crate) struct Running {
    worker: Worker,
    /// A short run without `chunk_rows` (under [`INLINE_WORK`], about 10 ms): the first
    /// `wait` makes it on the calling thread, with the GIL released, instead of on a thread
    /// (whose ~50 µs would be most of its cost). No Python signal handler can run until it
    /// has ended.
    #[pyo3(get)]
    inline: bool,
    /// In a mutex only to make the class `Sync` (a Python object may be dropped, or used, on
    /// another thread than the one that made it: Dask's and the sweep's threads); every use
    /// holds `&mut self` and reaches it with `get_mut`, without locking.
    rx: Mutex<Receiver<Rows>>,
    /// Blocks received and not yet taken.
    pending: Vec<Rows>,
    shared: Arc<Shared>,
    /// Energy balance error over the rows handed out so far.
    balance: BalanceError,
    finished: bool,
    n_dofs: usize,
    n_gaps: usize,
}

/// Prepares the run of one model spec (a dict built by `vibroimpact.simulate`), which begins
/// at the first `wait` (see `Running.inline`). `chunk_rows`: hand the recorded rows over in
/// blocks of that many (`take_rows`) instead of holding them all; `events`: collect solver
/// events (`take_events`).
#[pyfunction]
#[pyo3(signature = (spec, chunk_rows = None, events = false))]
pub(crate) fn start(
    spec: &Bound<'_, PyDict>,
    chunk_rows: Option<usize>,
    events: bool,
) -> PyResult<Running> {
    let job = convert::job_from_spec(spec, None)?;
    // an adaptive run's first step is `dt`: estimated at ten times the steps of that size
    let steps = job.settings.t_end / job.settings.dt
        * if job.settings.adaptive.is_some() {
            10.0
        } else {
            1.0
        };
    let n = job.system.n_dof() as f64;
    let work = steps * n.max(1.0).powi(2) * (job.system.gaps.len().max(1) as f64);
    let (tx, rx) = sync_channel(BLOCKS_IN_FLIGHT);
    let shared = Arc::new(Shared::default());
    let sink = ChannelSink {
        shared: shared.clone(),
        tx: Some(tx),
        chunk: chunk_rows,
        events,
    };
    let (n_dofs, n_gaps) = (job.settings.record_dofs.len(), job.system.n_gaps);
    Ok(Running {
        worker: Worker::Ready(Box::new((job, sink))),
        inline: chunk_rows.is_none() && work <= INLINE_WORK,
        rx: Mutex::new(rx),
        pending: Vec::new(),
        shared,
        balance: BalanceError::default(),
        finished: false,
        n_dofs,
        n_gaps,
    })
}

fn run(job: convert::Job, sink: &mut ChannelSink) -> Result<RunOutput, SimError> {
    let convert::Job {
        system,
        method,
        settings,
        x0,
        v0,
    } = job;
    simulate_streamed(&system, method, &settings, x0, v0, sink)
}

/// `blocks` as one block.
fn concat(mut blocks: Vec<Rows>) -> Rows {
    if blocks.len() == 1 {
        return blocks.pop().unwrap_or_default();
    }
    let mut all = Rows::default();
    for b in blocks {
        all.time.extend(b.time);
        all.displacement.extend(b.displacement);
        all.velocity.extend(b.velocity);
        all.acceleration.extend(b.acceleration);
        all.gap_penetration.extend(b.gap_penetration);
        all.gap_force.extend(b.gap_force);
        let (e, f) = (&mut all.energy, b.energy);
        e.kinetic.extend(f.kinetic);
        e.strain.extend(f.strain);
        e.contact_potential.extend(f.contact_potential);
        e.external_work.extend(f.external_work);
        e.damping_dissipated.extend(f.damping_dissipated);
        e.contact_dissipated.extend(f.contact_dissipated);
    }
    all
}

fn side(sign: f64) -> &'static str {
    if sign > 0.0 {
        "positive"
    } else if sign < 0.0 {
        "negative"
    } else {
        "radial"
    }
}

#[pymethods]
impl Running {
    /// Waits up to `timeout` s (GIL released) for a block of rows or the end of the run;
    /// returns whether the run has ended (every block has then been received).
    fn wait(&mut self, py: Python<'_>, timeout: f64) -> bool {
        if self.finished {
            return true;
        }
        if matches!(self.worker, Worker::Ready(_)) {
            let Worker::Ready(ready) = std::mem::replace(&mut self.worker, Worker::Taken) else {
                unreachable!("matched above")
            };
            let (job, mut sink) = *ready;
            self.worker = if self.inline {
                // the sink dropped after the run: the channel then reports its end
                Worker::Done(Box::new(py.detach(move || run(job, &mut sink))))
            } else {
                Worker::Thread(std::thread::spawn(move || run(job, &mut sink)))
            };
        }
        let rx = self.rx.get_mut().unwrap_or_else(|e| e.into_inner());
        let pending = &mut self.pending;
        let timeout = Duration::from_secs_f64(timeout.max(0.0));
        self.finished = py.detach(move || match rx.recv_timeout(timeout) {
            Ok(rows) => {
                pending.push(rows);
                false
            }
            Err(RecvTimeoutError::Timeout) => false,
            Err(RecvTimeoutError::Disconnected) => true,
        });
        self.finished
    }

    /// The rows received since the last call, as one dict of arrays (`time`,
    /// `displacement`, ..., `energy`), or None: the block `wait` received and those the
    /// channel held, at most [`BLOCKS_IN_FLIGHT`] (not those the core sends meanwhile, which
    /// the next poll takes), so a poll never holds more than `BLOCKS_IN_FLIGHT + 1` blocks.
    fn take_rows<'py>(&mut self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        let rx = self.rx.get_mut().unwrap_or_else(|e| e.into_inner());
        self.pending.extend(rx.try_iter().take(BLOCKS_IN_FLIGHT));
        if self.pending.is_empty() {
            return Ok(None);
        }
        let rows = concat(std::mem::take(&mut self.pending));
        self.balance.add(&rows.energy);
        let d = PyDict::new(py);
        rows_to_dict(&d, rows, self.n_dofs, self.n_gaps)?;
        Ok(Some(d))
    }

    /// The solver events since the last call (dicts with `kind`: `step-cut`,
    /// `contact-start`, `contact-end`, `impact`, `linear-solver`; `t`, `gap`, ...) and how many
    /// were dropped because the buffer was full.
    fn take_events<'py>(&mut self, py: Python<'py>) -> PyResult<(Bound<'py, PyList>, usize)> {
        let events =
            std::mem::take(&mut *self.shared.events.lock().unwrap_or_else(|e| e.into_inner()));
        let dropped = self.shared.dropped_events.swap(0, Ordering::Relaxed);
        let list = PyList::empty(py);
        for e in events {
            let d = PyDict::new(py);
            match e {
                Event::StepCut {
                    t,
                    dt,
                    gap,
                    penetration,
                    iterations,
                } => {
                    d.set_item("kind", "step-cut")?;
                    d.set_item("t", t)?;
                    d.set_item("dt", dt)?;
                    d.set_item("gap", gap)?;
                    d.set_item("penetration", penetration)?;
                    d.set_item("iterations", iterations)?;
                }
                Event::ContactStart {
                    t,
                    gap,
                    side: s,
                    speed,
                } => {
                    d.set_item("kind", "contact-start")?;
                    d.set_item("t", t)?;
                    d.set_item("gap", gap)?;
                    d.set_item("side", side(s))?;
                    d.set_item("speed", speed)?;
                }
                Event::ContactEnd {
                    t,
                    gap,
                    side: s,
                    speed,
                    steps,
                    iterations,
                } => {
                    d.set_item("kind", "contact-end")?;
                    d.set_item("t", t)?;
                    d.set_item("gap", gap)?;
                    d.set_item("side", side(s))?;
                    d.set_item("speed", speed)?;
                    d.set_item("steps", steps)?;
                    d.set_item("iterations", iterations)?;
                }
                Event::Impact {
                    t,
                    gap,
                    side: s,
                    v_in,
                    v_out,
                } => {
                    d.set_item("kind", "impact")?;
                    d.set_item("t", t)?;
                    d.set_item("gap", gap)?;
                    d.set_item("side", side(s))?;
                    d.set_item("v_in", v_in)?;
                    d.set_item("v_out", v_out)?;
                }
                Event::LinearSolver { dt, factor } => {
                    d.set_item("kind", "linear-solver")?;
                    d.set_item("dt", dt)?;
                    d.set_item("solver", factor.solver)?;
                    d.set_item("dofs", factor.dofs)?;
                    d.set_item("bandwidth", factor.bandwidth)?;
                    d.set_item("stored_values", factor.stored_values)?;
                }
            }
            list.append(d)?;
        }
        Ok((list, dropped))
    }

    /// The simulated time reached, s (updated every 64 steps).
    fn time(&self) -> f64 {
        f64::from_bits(self.shared.time.load(Ordering::Relaxed))
    }

    /// Waits for the end of the run and returns its output (the dict `simulate` returned:
    /// the rows not taken yet, the impact table, statistics, error).
    fn finish<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        while !self.wait(py, 3600.0) {}
        let out = match std::mem::replace(&mut self.worker, Worker::Taken) {
            Worker::Done(out) => *out,
            Worker::Thread(handle) => py
                .detach(|| handle.join())
                .map_err(|_| PyRuntimeError::new_err("the simulation thread panicked"))?,
            Worker::Ready(_) => unreachable!("wait begins the run"),
            Worker::Taken => return Err(PyRuntimeError::new_err("finish: already called")),
        };
        let mut out = out.map_err(to_py_err)?;
        let mut blocks: Vec<Rows> = std::mem::take(&mut self.pending);
        blocks.push(std::mem::take(&mut out.rows));
        let rows = concat(blocks);
        self.balance.add(&rows.energy);
        output_to_dict(py, out, rows, self.n_gaps, self.balance.value())
    }
}
