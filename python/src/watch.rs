//! Progress and cancellation of long calls: `progress=callable` and `cancel=CancelToken`.
//!
//! A long call (`Deformation.warp`, `Deformation.field`, `fit`, `register`) runs its library
//! computation on a worker thread with the GIL released, while the calling thread waits on
//! it and, every [`POLL`] and once at the end:
//!
//! * runs Python's signal handlers (`PyErr_CheckSignals`), so Ctrl-C raises
//!   `KeyboardInterrupt` during the call, not after it;
//! * calls `progress(done, total)` when `done` changed (on the calling thread, with the
//!   GIL: the callback may touch Python objects and a GUI's thread-safe signals);
//! * reads the `cancel` token (`CancelToken.cancel()` from any thread, e.g. a plugin's
//!   cancel button).
//!
//! An exception from the signal handlers or from `progress`, or a cancelled token, sets the
//! library's [`Cancel`] token: the computation stops at its next stopping point (a band of
//! rows, an iteration; see [`trimorph::cancel`]), the worker is joined (nothing keeps
//! running behind the caller's back), and the call raises that exception, or
//! `trimorph.Cancelled` for the token.

use crate::errors::TrimorphError;
use pyo3::create_exception;
use pyo3::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{mpsc, Arc};
use std::time::Duration;
use trimorph::cancel::Cancel;

/// How often the waiting thread looks at signals, progress and the token.
pub const POLL: Duration = Duration::from_millis(20);

create_exception!(
    trimorph,
    Cancelled,
    TrimorphError,
    "A call stopped because its `cancel` token (`trimorph.CancelToken`) was cancelled."
);

/// A token to cancel long calls from any thread: pass it as `cancel=` and call `cancel()`.
/// One token may serve several calls; once cancelled it stays cancelled.
#[pyclass(module = "trimorph", frozen)]
pub struct CancelToken {
    inner: Cancel,
}

#[pymethods]
impl CancelToken {
    #[new]
    fn new() -> CancelToken {
        CancelToken { inner: Cancel::new() }
    }

    /// Asks every call holding this token to stop (they raise `trimorph.Cancelled`).
    fn cancel(&self) {
        self.inner.cancel();
    }

    /// Whether `cancel()` was called.
    #[getter]
    fn cancelled(&self) -> bool {
        self.inner.is_cancelled()
    }

    fn __repr__(&self) -> String {
        let state = if self.inner.is_cancelled() { "True" } else { "False" };
        format!("CancelToken(cancelled={state})")
    }
}

/// What the computation shares with the waiting thread: the token it looks at and the
/// count of work done (rows, iterations) it reports.
pub struct Shared {
    /// The library's token: set on Ctrl-C, a raising `progress`, or a cancelled
    /// `CancelToken`.
    pub cancel: Cancel,
    done: Arc<AtomicU64>,
    total: AtomicU64,
}

impl Shared {
    /// Adds `n` units of work done.
    pub fn add(&self, n: u64) {
        self.done.fetch_add(n, Ordering::Relaxed);
    }

    /// The count of work done, for a callback the library keeps beyond this borrow (an
    /// `Arc<dyn Fn>` progress option).
    pub fn counter(&self) -> Arc<AtomicU64> {
        self.done.clone()
    }
}

/// The keyword arguments `progress` and `cancel` of a long call.
pub struct Watch<'py> {
    progress: Option<Bound<'py, PyAny>>,
    token: Option<Cancel>,
}

impl<'py> Watch<'py> {
    /// From the keywords; `progress` must be callable.
    pub fn new(
        progress: Option<Bound<'py, PyAny>>,
        cancel: Option<&Bound<'py, CancelToken>>,
    ) -> PyResult<Watch<'py>> {
        if let Some(p) = progress.as_ref().filter(|p| !p.is_callable()) {
            return Err(pyo3::exceptions::PyTypeError::new_err(format!(
                "progress must be callable as progress(done, total), got {}",
                p.get_type().name()?
            )));
        }
        Ok(Watch { progress, token: cancel.map(|c| c.get().inner.clone()) })
    }

    /// Runs `work` on a worker thread (see the module docs) with `total` units of work
    /// expected. `Ok` is the work's result; an exception from Ctrl-C or `progress`, or
    /// `Cancelled` for a cancelled token, is raised instead of it.
    pub fn run<T: Send>(
        &self,
        py: Python<'py>,
        total: u64,
        work: impl FnOnce(&Shared) -> T + Send,
    ) -> PyResult<T> {
        if self.token.as_ref().is_some_and(Cancel::is_cancelled) {
            return Err(Cancelled::new_err("cancelled before it started"));
        }
        let shared = Shared {
            cancel: Cancel::new(),
            done: Arc::new(AtomicU64::new(0)),
            total: AtomicU64::new(total),
        };
        let progress = self.progress.as_ref().map(|p| p.clone().unbind());
        let token = self.token.clone();
        let (result, raised) = py.detach(|| {
            std::thread::scope(|scope| {
                let (tx, rx) = mpsc::channel();
                let sh = &shared;
                let worker = scope.spawn(move || {
                    let r = work(sh);
                    let _ = tx.send(());
                    r
                });
                let mut raised: Option<PyErr> = None;
                let mut reported = None;
                loop {
                    let finished =
                        !matches!(rx.recv_timeout(POLL), Err(mpsc::RecvTimeoutError::Timeout));
                    if raised.is_none() {
                        raised = Python::attach(|py| {
                            if let Err(e) = py.check_signals() {
                                return Some(e);
                            }
                            if token.as_ref().is_some_and(Cancel::is_cancelled) {
                                return Some(Cancelled::new_err("cancelled"));
                            }
                            let now =
                                (sh.done.load(Ordering::Relaxed), sh.total.load(Ordering::Relaxed));
                            match &progress {
                                // The final report, (total, total), follows a success.
                                Some(p) if !finished && reported != Some(now) => {
                                    reported = Some(now);
                                    p.call1(py, now).err()
                                }
                                _ => None,
                            }
                        });
                        if raised.is_some() {
                            shared.cancel.cancel();
                        }
                    }
                    if finished {
                        break;
                    }
                }
                let result = worker.join();
                (result, raised)
            })
        });
        if let Some(e) = raised {
            return Err(e);
        }
        let result = match result {
            Ok(r) => r,
            Err(panic) => std::panic::resume_unwind(panic),
        };
        if let Some(p) = &self.progress {
            let total = shared.total.load(Ordering::Relaxed);
            p.call1((total, total))?;
        }
        Ok(result)
    }
}
