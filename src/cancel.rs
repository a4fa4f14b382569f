//! Stopping a long computation from outside: a [`Cancel`] token, shared by the caller and
//! the computation, and the [`Cancelled`] error the computation then returns.
//!
//! The computations that take one (the image warp between bands of rows, the fit between
//! Newton iterations, the registration between optimizer iterations) look at the token at
//! those points only, so a cancelled call returns within one band or one iteration, leaves
//! nothing half-written that it owns, and reports [`Cancelled`] instead of a result. The
//! token is an atomic flag: setting it from any thread (a GUI's cancel button, a Python
//! `KeyboardInterrupt` seen by the calling thread) is safe while workers read it.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// A shared stop flag (see the module docs). `Cancel::default()` is a token nobody can set
/// ([`Cancel::never`]); [`Cancel::new`] makes one that [`Cancel::cancel`] sets, through any
/// clone.
///
/// ```
/// use trimorph::cancel::Cancel;
/// let token = Cancel::new();
/// let seen_by_worker = token.clone();
/// assert!(!seen_by_worker.is_cancelled());
/// token.cancel();
/// assert!(seen_by_worker.is_cancelled());
/// assert!(seen_by_worker.check().is_err());
/// assert!(!Cancel::never().is_cancelled());
/// ```
#[derive(Clone, Debug, Default)]
pub struct Cancel(Option<Arc<AtomicBool>>);

impl Cancel {
    /// A token that [`Cancel::cancel`] can set.
    pub fn new() -> Cancel {
        Cancel(Some(Arc::new(AtomicBool::new(false))))
    }

    /// A token that is never set (what callers without a cancel button pass).
    pub fn never() -> Cancel {
        Cancel(None)
    }

    /// Asks every holder of a clone to stop (a no-op on [`Cancel::never`]).
    pub fn cancel(&self) {
        if let Some(flag) = &self.0 {
            flag.store(true, Ordering::Relaxed);
        }
    }

    /// Whether [`Cancel::cancel`] was called on this token or a clone.
    pub fn is_cancelled(&self) -> bool {
        self.0.as_ref().is_some_and(|f| f.load(Ordering::Relaxed))
    }

    /// `Err(Cancelled)` once cancelled: `token.check()?` at a stopping point.
    pub fn check(&self) -> Result<(), Cancelled> {
        if self.is_cancelled() {
            Err(Cancelled)
        } else {
            Ok(())
        }
    }
}

/// Two tokens are equal when they are the same flag (or both [`Cancel::never`]), so option
/// structs holding one keep their `PartialEq`.
impl PartialEq for Cancel {
    fn eq(&self, other: &Cancel) -> bool {
        match (&self.0, &other.0) {
            (None, None) => true,
            (Some(a), Some(b)) => Arc::ptr_eq(a, b),
            _ => false,
        }
    }
}

/// A computation stopped because its [`Cancel`] token was set.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error("cancelled")]
pub struct Cancelled;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_token_set_on_one_thread_is_seen_on_another() {
        let t = Cancel::new();
        let seen = t.clone();
        let h = std::thread::spawn(move || {
            while !seen.is_cancelled() {
                std::thread::yield_now();
            }
            seen.check()
        });
        t.cancel();
        assert_eq!(h.join().unwrap(), Err(Cancelled));
        assert_eq!(t, t.clone());
        assert_ne!(t, Cancel::new());
        assert_eq!(Cancel::never(), Cancel::default());
        Cancel::never().cancel();
        assert!(Cancel::never().check().is_ok());
    }
}
