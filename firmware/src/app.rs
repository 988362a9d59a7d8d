//! The application both builds run: power-up (commission when no valid parameters are
//! stored, otherwise straight into service), then the service loop answering the host. Its
//! logic is `motor_id_shared::device::service`; this module adds the record buffer, the fit's
//! workspace, the limits, the status LED and the log lines.

use motor_id_shared::device::hardware::{Drive, Hardware, Link, ParamStore, Watchdog};
use motor_id_shared::device::job::JobEnd;
use motor_id_shared::device::record_store::RecordStore;
use motor_id_shared::device::service::{Boot, Service};
use motor_id_shared::fit::workspace::FitWorkspace;
use motor_id_shared::wire::limits::Limits;
use motor_id_shared::wire::protocol::{MotorReport, NotStored};
use motor_id_shared::wire::stored::STORE_VERSION;

/// Longest record the board holds (2,000 samples of voltage, speed and current: 24 KB).
pub const MAX_SAMPLES: usize = 2000;

/// Limits of the commissioning experiment until the host sets others (`motor-id board
/// config`, stored beside the parameters and read at every power-up): the conservative
/// defaults (50 V, 40 A, 500 rad/s, 60 s; the probe sizes the experiment within them for
/// any motor).
pub const LIMITS: Limits = Limits::DEFAULT;

/// What the status LED shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub enum State {
    /// Lit: valid parameters (stored or just commissioned), in service.
    InService,
    /// Dark: no valid parameters (commissioning failed or was aborted): waiting for the host.
    NoParameters,
}

/// The status LED.
pub trait StatusLed {
    /// Show `state`.
    fn show(&mut self, state: State);
}

/// Run the application forever.
pub fn run<L: Link, D: Drive, P: ParamStore, W: Watchdog>(
    hw: &'static mut Hardware<L, D, P, W>,
    store: &'static mut RecordStore<MAX_SAMPLES>,
    workspace: &'static FitWorkspace,
    mut led: impl StatusLed,
) -> ! {
    // Each commissioning record's sample the mean of the drive's readings over its step
    // (`model::step_mean`): √m less noise, modelled exactly.
    let mut service = Service::new(store, LIMITS)
        .with_workspace(workspace)
        .with_averaged_records(true);
    led.show(State::NoParameters);
    defmt::info!("motor-id firmware: power-up");
    let state = match service.boot(hw) {
        Boot::InService(r) => {
            defmt::info!(
                "valid parameters stored (rmse {} rad/s): in service",
                r.rmse_omega
            );
            State::InService
        }
        Boot::Commissioned { report, found } => {
            log_not_stored(found);
            log_report(&report);
            State::InService
        }
        Boot::NotCommissioned { end, found } => {
            log_not_stored(found);
            match end {
                JobEnd::Aborted => defmt::warn!("commissioning aborted by the host: no parameters"),
                JobEnd::Refused(why) => {
                    defmt::warn!("commissioning failed ({}): no parameters", why)
                }
            }
            State::NoParameters
        }
    };
    led.show(state);
    loop {
        service.poll(hw);
    }
}

/// Log why power-up commissions (`Empty`, `OtherLayout { found }` of another firmware's
/// store, or `Corrupt`: never read as parameters).
fn log_not_stored(found: NotStored) {
    defmt::info!(
        "no parameters this firmware reads (store layout {}): {}; commissioning",
        STORE_VERSION,
        found
    );
}

/// Log a new report (each estimate by its parameter code, `docs/CONTRACTS.md`; a NaN `std`:
/// not pinned).
fn log_report(report: &MotorReport) {
    defmt::info!("commissioned and stored: {}", report);
}
