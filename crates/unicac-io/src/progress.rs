//! The one progress protocol of long library work (`unicac dataset build`, `unicac bench`, `unicac
//! tolerance`): the library names each stage with its amount of work and reports work done as it goes;
//! the face decides how to show it (a bar on a terminal, a timed line in a log, nothing in tests), so
//! libraries never print.

/// Where a long job reports how far it is. Calls may come from several threads.
pub trait Progress: Sync {
    /// A stage with `total` units of work starts (pairs, trials, test pixels: the stage's name says
    /// which); the previous stage, if any, is over.
    fn stage(&self, name: &str, total: usize);
    /// `count` more units of the current stage are done.
    fn advance(&self, count: usize);
    /// A message for the user (cache hits, warnings), shown above any bar.
    fn note(&self, message: &str);
}

/// Progress that goes nowhere (tests, library callers without a display).
pub struct Silent;

impl Progress for Silent {
    fn stage(&self, _: &str, _: usize) {}
    fn advance(&self, _: usize) {}
    fn note(&self, _: &str) {}
}
