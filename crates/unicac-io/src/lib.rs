//! # unicac-io
//!
//! The one output-file policy of unicac (every command and stage that writes files calls it):
//!
//! - [`OutputPlan`]: before any work, the outputs of a run are checked against its inputs (an output
//!   is never an input, compared by file identity, not by spelling) and against each other (two
//!   outputs never share a path);
//! - [`require_extension`]: an output's extension must name the format written (or the format follows
//!   the extension: the caller picks it with [`extension_of`]);
//! - [`write_atomically`] / [`write_with`] / [`write_via_path`]: a file appears complete or not at all
//!   (a dot-named temporary sibling, synced, then renamed over the target); [`write_new_atomically`]
//!   the same, only where no file exists yet (an exclusive claim);
//! - [`clean_stale_temporaries`] / [`clean_stale_temporaries_under`]: temporaries left by killed runs
//!   are removed on the next run; a live writer's (a concurrent shard's) are kept;
//! - [`read_capped`]: an input read whole is a regular file within a stated size (never a device, a
//!   FIFO or a folder, which could block or never end).
//!
//! - [`digest`]: the one SHA-256 (file hashes, cache keys from canonical JSON, derived seeds);
//! - [`counter_random`]: the one counter-based random source (SplitMix64; CPU and GPU alike);
//! - [`counter_draws`]: uniform, normal and Poisson draws from one sample's counter stream (sensor noise);
//! - [`progress`]: the one progress protocol of long library work;
//! - [`choice`]: `named_choice!`, enums parsed from and printed as one table of names;
//! - [`memory`]: large buffers advised onto huge pages (fewer first-touch page faults).
//!
//! std, libc (one `madvise`), thiserror, sha2 and serde (JSON) only, so that every crate (optics, image, plot, sim, dataset, bench)
//! can depend on it.

mod atomic;
pub mod choice;
pub mod counter_draws;
pub mod counter_random;
pub mod digest;
pub mod memory;
mod plan;
pub mod progress;
mod read;
pub mod serde_skip;
pub mod shard;

pub use atomic::{
    clean_stale_temporaries, clean_stale_temporaries_under, is_temporary_name, temporary_sibling,
    write_atomically, write_new_atomically, write_via_path, write_with,
};
pub use plan::{extension_of, require_extension, OutputError, OutputPlan};
pub use read::read_capped;
pub use shard::Shard;
