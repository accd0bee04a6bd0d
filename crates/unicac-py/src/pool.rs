//! Where native work runs: with the GIL released, on this process's own rayon thread pool.
//!
//! A forked child (PyTorch DataLoader workers on Linux) inherits the parent's memory but none of its
//! threads: a rayon pool the parent started is dead in the child, and work sent to it would wait
//! forever. So the bindings never use rayon's global pool: each process builds its own pool on first
//! use, and a call that finds the pool was built by another process (the parent, before `fork`)
//! builds a fresh one. The core crates' `par_iter`s run on whichever pool `install` names.

use pyo3::marker::Ungil;
use pyo3::prelude::*;
use rayon::{ThreadPool, ThreadPoolBuilder};
use std::sync::{Arc, Mutex};

/// The pool and the process that built it.
static POOL: Mutex<Option<(u32, Arc<ThreadPool>)>> = Mutex::new(None);

/// This process's pool (None if the operating system refuses threads: then rayon's global pool).
fn pool() -> Option<Arc<ThreadPool>> {
    let pid = std::process::id();
    let mut slot = POOL.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
    if let Some((owner, pool)) = slot.as_ref() {
        if *owner == pid {
            return Some(pool.clone());
        }
    }
    // A pool inherited through fork has no threads here; dropping it would signal threads that do
    // not exist, so it is leaked on purpose (once per forked process).
    if let Some(stale) = slot.take() {
        std::mem::forget(stale);
    }
    let pool = Arc::new(
        ThreadPoolBuilder::new()
            .thread_name(|i| format!("unicac-{i}"))
            .build()
            .ok()?,
    );
    *slot = Some((pid, pool.clone()));
    Some(pool)
}

/// Runs `work` with the GIL released on this process's thread pool.
pub fn detach<T, F>(py: Python<'_>, work: F) -> T
where
    F: Ungil + FnOnce() -> T + Send,
    T: Ungil + Send,
{
    py.detach(|| match pool() {
        Some(pool) => pool.install(work),
        None => work(),
    })
}
