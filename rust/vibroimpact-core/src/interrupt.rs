//! A process-wide interrupt flag (Ctrl-C, SIGTERM): the time loops poll it every
//! [`CHECK_EVERY`] steps and stop with [`SimError::Interrupted`](crate::SimError::Interrupted),
//! returning the results up to then. Setting it is async-signal-safe (one atomic store), so a
//! signal handler or another thread may call [`request`] while a run is in progress.

use std::sync::atomic::{AtomicBool, Ordering};

static REQUESTED: AtomicBool = AtomicBool::new(false);

/// Accepted steps between two polls of the flag (and checks of the energy for a blow-up,
/// `SimError::EnergyGrowth`): a relaxed load and, for the energy, two n×n quadratic forms
/// every 64 steps cost nothing measurable, and a run answers within microseconds.
pub const CHECK_EVERY: usize = 64;

/// Asks every run in progress (and every run started before [`clear`]) to stop.
pub fn request() {
    REQUESTED.store(true, Ordering::Relaxed);
}

/// Withdraws the request (call before starting a run that should not see an old one).
pub fn clear() {
    REQUESTED.store(false, Ordering::Relaxed);
}

/// Whether an interrupt has been requested.
pub fn requested() -> bool {
    REQUESTED.load(Ordering::Relaxed)
}
