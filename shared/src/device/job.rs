//! How a long job (an experiment or an identification) ends early: an abort asked by the
//! host, or a refusal, reported on the link.

use crate::device::hardware::Link;
use crate::wire::protocol::{BoardMessage, HostMessage, Refusal};

/// Why a job ended without a result.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum JobEnd {
    /// The host asked to abort.
    Aborted,
    /// A check failed; the reason as reported to the host.
    Refused(Refusal),
}

/// During a job: `true` when the host asked to abort; any other request is answered
/// [`Refusal::Busy`].
pub(super) fn abort_requested(link: &mut impl Link) -> bool {
    match link.poll() {
        Some(HostMessage::Abort) => true,
        Some(_) => {
            refuse(link, Refusal::Busy);
            false
        }
        None => false,
    }
}

/// Report a job's end on the link and return it as the error.
pub(super) fn fail<T>(end: JobEnd, link: &mut impl Link) -> Result<T, JobEnd> {
    link.send(&match end {
        JobEnd::Aborted => BoardMessage::Aborted,
        JobEnd::Refused(r) => BoardMessage::Refused(r),
    });
    Err(end)
}

/// Send a refusal. Built here at run time: a constant message written at each call site
/// would be a whole [`BoardMessage`] in flash per site (the size of its largest variant, a
/// report).
#[inline(never)]
pub(super) fn refuse(link: &mut impl Link, why: Refusal) {
    link.send(&BoardMessage::Refused(why));
}
