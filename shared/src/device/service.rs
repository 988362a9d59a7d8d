//! The drive board's application, independent of any register: at power-up it commissions a
//! motor it has no valid parameters for (safety checks, bounded experiment, identification,
//! store) or goes straight into service; in service it answers the host's
//! [`crate::wire::protocol`] requests over a [`Link`], identifies from a record the host streams in,
//! and commissions again on request. The board and QEMU builds implement the traits
//! ([`Link`], [`Drive`], [`ParamStore`], [`Watchdog`]); the tests below drive it with the
//! simulated plant of [`crate::device::plant`].

use crate::fit::identify::{identify, IdentifyConfig, Progress, Stage};
use crate::model::params::ParamId;
use crate::model::profile::{Experiment, Profile};
use crate::wire::protocol::Estimate;
use crate::wire::protocol::{
    BoardMessage, HostMessage, JobStage, MotorReport, Refusal, PROTOCOL_VERSION,
};
use crate::model::record::Record;
use crate::fit::space::ProblemSpec;
use core::ops::ControlFlow;

/// The byte link to the host, message by message.
pub trait Link {
    /// Send one message.
    fn send(&mut self, msg: &BoardMessage);
    /// A message if one has arrived (never blocks).
    fn poll(&mut self) -> Option<HostMessage>;
}

/// One sample of the drive's sensors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// Tacho speed [rad/s].
    pub omega: f32,
    /// Armature current [A].
    pub current: f32,
}

/// The power stage and its sensors, sampled at a fixed rate.
pub trait Drive {
    /// Sample period [s].
    fn dt(&self) -> f32;
    /// Wait for the next sample, return it, then apply `volts` until the one after.
    fn step(&mut self, volts: f32) -> Sample;
    /// Wait for the next sample, return it, then keep every bridge switch off until the one
    /// after (open circuit: the motor coasts; the next [`Drive::step`] drives it again).
    fn coast(&mut self) -> Sample;
    /// [`Drive::step`] or [`Drive::coast`], as `bridge` says.
    fn apply(&mut self, bridge: Bridge) -> Sample {
        match bridge {
            Bridge::Drive(volts) => self.step(volts),
            Bridge::Open => self.coast(),
        }
    }
    /// Remove drive (all bridge switches off: the motor coasts).
    fn stop(&mut self);
}

/// Non-volatile storage of the identified motor.
pub trait ParamStore {
    /// The stored motor, if valid.
    fn load(&mut self) -> Option<MotorReport>;
    /// Store `report`.
    fn save(&mut self, report: &MotorReport);
    /// Erase.
    fn clear(&mut self);
}

/// The independent watchdog: it stays on during experiments and identification, which feed
/// it at every sample and every optimiser iteration.
pub trait Watchdog {
    /// Restart the watchdog's count-down.
    fn feed(&mut self);
}

/// For builds without a watchdog (QEMU does not model the IWDG).
pub struct NoWatchdog;

impl Watchdog for NoWatchdog {
    fn feed(&mut self) {}
}

/// The board as the application sees it: link, drive, parameter store, watchdog.
pub struct Hardware<L, D, P, W> {
    /// Link to the host.
    pub link: L,
    /// Power stage and sensors.
    pub drive: D,
    /// Non-volatile parameters.
    pub params: P,
    /// Independent watchdog.
    pub watchdog: W,
}

/// Seed of the identification that power-up commissioning runs.
pub const BOOT_SEED: u64 = 1;

/// Samples read at 0 V before an experiment (safety checks).
pub const SAFETY_SAMPLES: usize = 32;

/// Samples the safety checks wait at 0 V for the motor to come to rest.
pub const REST_WAIT_SAMPLES: usize = 2048;

/// How power-up went.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Boot {
    /// Valid parameters were stored: straight into service.
    InService(MotorReport),
    /// Nothing valid was stored: the motor was commissioned and its parameters stored.
    Commissioned(MotorReport),
    /// Commissioning failed (safety check, trip, invalid data) or was aborted; the board
    /// serves the host without parameters.
    NotCommissioned(JobEnd),
}

/// Why a job ended without a result.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum JobEnd {
    /// The host asked to abort.
    Aborted,
    /// A check failed; the reason as reported to the host.
    Refused(Refusal),
}

/// Limits of the commissioning experiment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits {
    /// Largest armature voltage applied [V].
    pub voltage: f32,
    /// Trip above this |current| [A].
    pub current: f32,
    /// Trip above this |speed| [rad/s].
    pub speed: f32,
}

/// Buffers of one record, in fixed memory.
pub struct RecordStore<const N: usize> {
    dt: f32,
    len: usize,
    expected: usize,
    with_current: bool,
    /// First sample of the coast-down (commissioning records only).
    coast_from: Option<usize>,
    v: [f32; N],
    omega: [f32; N],
    current: [f32; N],
}

impl<const N: usize> Default for RecordStore<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> RecordStore<N> {
    /// Empty buffers (const, for a `static`).
    pub const fn new() -> Self {
        RecordStore {
            dt: 0.0,
            len: 0,
            expected: 0,
            with_current: false,
            coast_from: None,
            v: [0.0; N],
            omega: [0.0; N],
            current: [0.0; N],
        }
    }

    fn record(&self) -> Record<'_> {
        Record {
            dt: self.dt,
            v: &self.v[..self.len],
            omega: &self.omega[..self.len],
            current: self.with_current.then(|| &self.current[..self.len]),
            load: None,
            coast_from: self.coast_from,
        }
    }
}

/// The application state.
pub struct Service<'s, const N: usize> {
    store: &'s mut RecordStore<N>,
    session: bool,
    limits: Limits,
}

/// Report of an identification in the message form.
pub fn motor_report(id: &crate::fit::identify::Identification) -> MotorReport {
    // A free parameter's value and standard deviation (NaN when not pinned); `None` for a
    // parameter that was not identified.
    let estimate = |p: ParamId| {
        let certainty = id.identifiability.params.iter().find(|c| c.id == p)?;
        Some(Estimate {
            value: id.params.get(p),
            std: certainty.std.unwrap_or(f32::NAN),
        })
    };
    let mut params = [0.0f32; 5];
    let mut std = [f32::NAN; 5];
    for (k, p) in ParamId::MOTOR.iter().enumerate() {
        params[k] = id.params.get(*p);
        if let Some(e) = estimate(*p) {
            std[k] = e.std;
        }
    }
    MotorReport {
        params,
        std,
        friction: estimate(ParamId::Tc),
        rmse_omega: id.cost.rmse_omega,
        evaluations: id.evaluations,
        rank: id.identifiability.rank as u8,
    }
}

/// During a job: `true` when the host asked to abort; any other request is answered
/// [`Refusal::Busy`].
fn abort_requested(link: &mut impl Link) -> bool {
    match link.poll() {
        Some(HostMessage::Abort) => true,
        Some(_) => {
            link.send(&BoardMessage::Refused(Refusal::Busy));
            false
        }
        None => false,
    }
}

/// Report a job's end on the link and return it as the error.
fn fail<T>(end: JobEnd, link: &mut impl Link) -> Result<T, JobEnd> {
    link.send(&match end {
        JobEnd::Aborted => BoardMessage::Aborted,
        JobEnd::Refused(r) => BoardMessage::Refused(r),
    });
    Err(end)
}

impl<'s, const N: usize> Service<'s, N> {
    /// A service using `store` for records, within `limits` when commissioning.
    pub fn new(store: &'s mut RecordStore<N>, limits: Limits) -> Self {
        Service {
            store,
            session: false,
            limits,
        }
    }

    /// Power-up: into service with valid stored parameters, otherwise self-commissioning
    /// (its progress and result go out on the link for whoever listens).
    pub fn boot<L: Link, D: Drive, P: ParamStore, W: Watchdog>(
        &mut self,
        hw: &mut Hardware<L, D, P, W>,
    ) -> Boot {
        hw.watchdog.feed();
        if let Some(stored) = hw.params.load() {
            return Boot::InService(stored);
        }
        match self.commission(BOOT_SEED, hw) {
            Ok(report) => Boot::Commissioned(report),
            Err(end) => Boot::NotCommissioned(end),
        }
    }

    /// One turn of the service loop: feed the watchdog, handle a request if one came.
    pub fn poll<L: Link, D: Drive, P: ParamStore, W: Watchdog>(
        &mut self,
        hw: &mut Hardware<L, D, P, W>,
    ) {
        hw.watchdog.feed();
        if let Some(msg) = hw.link.poll() {
            self.handle(msg, hw);
        }
    }

    /// Handle one request.
    pub fn handle<L: Link, D: Drive, P: ParamStore, W: Watchdog>(
        &mut self,
        msg: HostMessage,
        hw: &mut Hardware<L, D, P, W>,
    ) {
        if let HostMessage::Hello { version } = msg {
            if version == PROTOCOL_VERSION {
                self.session = true;
                hw.link.send(&BoardMessage::Hello {
                    version: PROTOCOL_VERSION,
                    max_samples: N as u32,
                });
            } else {
                self.session = false;
                hw.link
                    .send(&BoardMessage::Refused(Refusal::VersionMismatch {
                        board: PROTOCOL_VERSION,
                    }));
            }
            return;
        }
        if !self.session {
            hw.link.send(&BoardMessage::Refused(Refusal::NoSession));
            return;
        }
        match msg {
            HostMessage::Hello { .. } => {}
            HostMessage::IdentifyBegin {
                dt,
                samples,
                with_current,
            } => {
                if samples as usize > N {
                    hw.link.send(&BoardMessage::Refused(Refusal::RecordTooLong {
                        max: N as u32,
                    }));
                    return;
                }
                let s = &mut *self.store;
                s.dt = dt;
                s.len = 0;
                s.expected = samples as usize;
                s.with_current = with_current;
                s.coast_from = None;
                hw.link.send(&BoardMessage::ChunkOk { next: 0 });
            }
            HostMessage::RecordChunk {
                offset,
                v,
                omega,
                current,
            } => {
                let s = &mut *self.store;
                let n = v.len();
                // A repeat of the last chunk (its acknowledgement was lost) is acknowledged again.
                if n > 0 && offset as usize + n == s.len {
                    hw.link.send(&BoardMessage::ChunkOk { next: s.len as u32 });
                    return;
                }
                let ok = offset as usize == s.len
                    && omega.len() == n
                    && (!s.with_current || current.len() == n)
                    && s.len + n <= s.expected;
                if !ok {
                    hw.link.send(&BoardMessage::Refused(Refusal::BadChunk));
                    return;
                }
                for k in 0..n {
                    s.v[s.len + k] = v[k];
                    s.omega[s.len + k] = omega[k];
                    s.current[s.len + k] = if s.with_current { current[k] } else { 0.0 };
                }
                s.len += n;
                hw.link.send(&BoardMessage::ChunkOk { next: s.len as u32 });
            }
            HostMessage::Identify { seed, pipeline } => {
                if self.store.len != self.store.expected || self.store.len == 0 {
                    hw.link.send(&BoardMessage::Refused(Refusal::BadChunk));
                    return;
                }
                // The host's settings of the same name, so that the answer is bit-identical.
                let cfg = pipeline.config(seed);
                // Failures have been reported on the link.
                let _ = self.identify_and_report(&ProblemSpec::default(), &cfg, hw, false);
            }
            HostMessage::Commission { seed } => {
                // The result or the failure has been reported on the link.
                let _ = self.commission(seed, hw);
            }
            HostMessage::ReadParams => {
                let stored = hw.params.load();
                hw.link.send(&BoardMessage::Params(stored));
            }
            HostMessage::ClearParams => {
                hw.params.clear();
                hw.link.send(&BoardMessage::Cleared);
            }
            HostMessage::Abort => hw.link.send(&BoardMessage::Aborted),
        }
    }

    /// Identify from the stored record, reporting progress and feeding the watchdog at every
    /// iteration; `Abort` from the host stops it. With `store`, the result is kept.
    fn identify_and_report<L: Link, D: Drive, P: ParamStore, W: Watchdog>(
        &mut self,
        spec: &ProblemSpec,
        cfg: &IdentifyConfig,
        hw: &mut Hardware<L, D, P, W>,
        store: bool,
    ) -> Result<MotorReport, JobEnd> {
        let record = [self.store.record()];
        let mut aborted = false;
        let (link, watchdog) = (&mut hw.link, &mut hw.watchdog);
        let result = identify(&record, spec, cfg, |p: &Progress| {
            watchdog.feed();
            link.send(&BoardMessage::Progress {
                stage: match p.stage {
                    Stage::Search => JobStage::Search,
                    Stage::Refine => JobStage::Refine,
                },
                iteration: p.iteration,
                evaluations: p.evaluations,
                best: p.best,
            });
            if abort_requested(link) {
                aborted = true;
                return ControlFlow::Break(());
            }
            ControlFlow::Continue(())
        });
        hw.watchdog.feed();
        let end = match result {
            _ if aborted => JobEnd::Aborted,
            Ok(id) => {
                let report = motor_report(&id);
                if store {
                    hw.params.save(&report);
                }
                hw.link.send(&BoardMessage::Identified(report));
                return Ok(report);
            }
            Err(crate::Error::InvalidConfig) => JobEnd::Refused(Refusal::PipelineTooLarge),
            Err(_) => JobEnd::Refused(Refusal::InvalidRecord),
        };
        fail(end, &mut hw.link)
    }

    /// Safety checks before any voltage is applied, at 0 V: the sensors read finite values;
    /// the motor comes to rest (mean |speed| over [`SAFETY_SAMPLES`] under 2 % of the speed
    /// limit) within [`REST_WAIT_SAMPLES`] (it may still be turning from a previous run);
    /// then the current sensor shows no offset (mean |current| under 2 % of the limit).
    fn safety_checks(
        &self,
        drive: &mut impl Drive,
        watchdog: &mut impl Watchdog,
    ) -> Result<(), Refusal> {
        for _ in 0..REST_WAIT_SAMPLES / SAFETY_SAMPLES {
            let (mut omega, mut current) = (0.0f32, 0.0f32);
            for _ in 0..SAFETY_SAMPLES {
                watchdog.feed();
                let s = drive.step(0.0);
                if !(s.omega.is_finite() && s.current.is_finite()) {
                    return Err(Refusal::SensorFault);
                }
                omega += s.omega;
                current += s.current;
            }
            let n = SAFETY_SAMPLES as f32;
            if (omega / n).abs() <= 0.02 * self.limits.speed {
                if (current / n).abs() > 0.02 * self.limits.current {
                    return Err(Refusal::SensorFault);
                }
                return Ok(());
            }
        }
        Err(Refusal::NotAtRest)
    }

    /// Self-commissioning: safety checks, then a bounded experiment over the record's
    /// length (see [`commissioning_input`]: seed Section 6 speed changes, then a coast-down
    /// for friction; a trip of the current or speed limit stops the drive and aborts), read
    /// on tacho and current, identification in fixed memory with progress (the board
    /// pipeline, Coulomb friction free: [`commissioning_spec`]), store, report.
    pub fn commission<L: Link, D: Drive, P: ParamStore, W: Watchdog>(
        &mut self,
        seed: u64,
        hw: &mut Hardware<L, D, P, W>,
    ) -> Result<MotorReport, JobEnd> {
        if let Err(r) = self.safety_checks(&mut hw.drive, &mut hw.watchdog) {
            hw.drive.stop();
            return fail(JobEnd::Refused(r), &mut hw.link);
        }
        let dt = hw.drive.dt();
        let s = &mut *self.store;
        s.dt = dt;
        s.with_current = true;
        s.len = 0;
        s.expected = N;
        s.coast_from = Some(coast_start(N));
        for k in 0..N {
            hw.watchdog.feed();
            let input = commissioning_input(k, N, dt, self.limits.voltage);
            let sample = hw.drive.apply(input);
            let within = sample.current.abs() <= self.limits.current
                && sample.omega.abs() <= self.limits.speed;
            if !within {
                hw.drive.stop();
                return fail(JobEnd::Refused(Refusal::Trip), &mut hw.link);
            }
            s.v[k] = input.recorded_volts();
            s.omega[k] = sample.omega;
            s.current[k] = sample.current;
            s.len = k + 1;
            if k % 256 == 0 {
                hw.link.send(&BoardMessage::Progress {
                    stage: JobStage::Experiment,
                    iteration: k as u32,
                    evaluations: 0,
                    best: 0.0,
                });
                if abort_requested(&mut hw.link) {
                    hw.drive.stop();
                    return fail(JobEnd::Aborted, &mut hw.link);
                }
            }
        }
        hw.drive.stop();
        self.identify_and_report(
            &commissioning_spec(),
            &IdentifyConfig::board(seed),
            hw,
            true,
        )
    }
}

/// What the bridge does over one sample of the commissioning experiment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Bridge {
    /// Apply this armature voltage [V].
    Drive(f32),
    /// Every switch off: the motor coasts.
    Open,
}

impl Bridge {
    /// The voltage column of the record: the applied voltage, 0 where the bridge is open
    /// (not applied; the record's `coast_from` says so).
    pub fn recorded_volts(self) -> f32 {
        match self {
            Bridge::Drive(volts) => volts,
            Bridge::Open => 0.0,
        }
    }
}

/// First sample of the coast-down in a commissioning record of `n` samples: the last
/// quarter coasts.
pub const fn coast_start(n: usize) -> usize {
    n - n / 4
}

/// Input of sample `k` of the commissioning experiment of `n` samples at step `dt` within
/// `voltage`: the voltage steps ½ → 1 → ¼ of the limit ([`Profile::Steps`], seed Section 6
/// speed changes) over the first three quarters, then a coast-down (bridge open) over the
/// last quarter. The steps excite the electrical and mechanical modes with the current
/// measured; the coast-down shows the friction alone (seed Eq. 4 with `i = 0`), which
/// separates Coulomb from viscous friction without the electrical parameters.
pub fn commissioning_input(k: usize, n: usize, dt: f32, voltage: f32) -> Bridge {
    let coast_from = coast_start(n);
    if k >= coast_from {
        return Bridge::Open;
    }
    let steps = Experiment {
        profile: Profile::Steps,
        voltage,
        duration: dt * coast_from as f32,
        load_torque: 0.0,
    };
    // min/max rather than clamp: clamp's NaN/order assertion would link float formatting
    // (about 10 KB of flash) for a panic that cannot happen here.
    Bridge::Drive(steps.at(k as f32 * dt).v.min(voltage).max(-voltage))
}

/// The problem a board solves when it commissions itself: the five motor parameters within
/// the seed's Table 1 and Coulomb friction `tc` (which the coast-down pins), the other
/// effects left out.
pub fn commissioning_spec() -> ProblemSpec {
    let mut spec = ProblemSpec::default();
    spec.free(ParamId::Tc);
    spec
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::params::ModelParams;
    use crate::device::plant::{SimulatedPlant, DEMO_FRICTION};
    use std::collections::VecDeque;

    /// A link whose incoming requests are queued, each released after `after` polls.
    #[derive(Default)]
    struct TestLink {
        incoming: VecDeque<(u32, HostMessage)>,
        polls: u32,
        sent: Vec<BoardMessage>,
    }

    impl Link for TestLink {
        fn send(&mut self, msg: &BoardMessage) {
            self.sent.push(msg.clone());
        }
        fn poll(&mut self) -> Option<HostMessage> {
            self.polls += 1;
            match self.incoming.front() {
                Some((after, _)) if self.polls > *after => self.incoming.pop_front().map(|m| m.1),
                _ => None,
            }
        }
    }

    #[derive(Default)]
    struct RamParams(Option<MotorReport>, u32);

    impl ParamStore for RamParams {
        fn load(&mut self) -> Option<MotorReport> {
            self.0
        }
        fn save(&mut self, report: &MotorReport) {
            self.0 = Some(*report);
            self.1 += 1;
        }
        fn clear(&mut self) {
            self.0 = None;
        }
    }

    #[derive(Default)]
    struct CountingWatchdog(u32);

    impl Watchdog for CountingWatchdog {
        fn feed(&mut self) {
            self.0 += 1;
        }
    }

    const LIMITS: Limits = Limits {
        voltage: 50.0,
        current: 40.0,
        speed: 500.0,
    };
    const SAMPLES: usize = 2000;

    type TestHardware = Hardware<TestLink, SimulatedPlant, RamParams, CountingWatchdog>;

    fn hardware(plant: SimulatedPlant) -> TestHardware {
        Hardware {
            link: TestLink::default(),
            drive: plant,
            params: RamParams::default(),
            watchdog: CountingWatchdog::default(),
        }
    }

    /// The seed's motor with Coulomb friction `tc`, sampled at 100 Hz with sensor noise.
    fn plant_with_friction(tc: f32) -> SimulatedPlant {
        let p = ModelParams::SEED_MOTOR.with(ParamId::Tc, tc);
        SimulatedPlant::new(&p, 0.01, 0.5, 0.02, 7).unwrap()
    }

    fn seed_plant() -> SimulatedPlant {
        plant_with_friction(DEMO_FRICTION)
    }

    fn progress_count(sent: &[BoardMessage]) -> u32 {
        sent.iter()
            .filter(|m| matches!(m, BoardMessage::Progress { .. }))
            .count() as u32
    }

    #[test]
    fn first_power_up_commissions_then_boots_into_service() {
        let mut store = RecordStore::<SAMPLES>::new();
        let mut service = Service::new(&mut store, LIMITS);
        let mut hw = hardware(seed_plant());
        let Boot::Commissioned(report) = service.boot(&mut hw) else {
            panic!("expected commissioning, got {:?}", hw.link.sent.last());
        };
        let truth = [3.412, 0.0573, 0.0424, 0.00267, 0.1604];
        for (got, want) in report.params.iter().zip(truth) {
            assert!((got / want - 1.0).abs() < 0.03, "{got} vs {want}");
        }
        let friction = report.friction.expect("commissioning identifies friction");
        assert!(
            (friction.value / DEMO_FRICTION - 1.0).abs() < 0.03,
            "tc {friction:?}"
        );
        assert!(friction.std < 0.1 * DEMO_FRICTION, "tc {friction:?}");
        assert_eq!(report.rank, 6, "speed, current and coast-down pin all six");
        assert_eq!(hw.params.0, Some(report));
        assert_eq!(hw.drive.stopped, 1, "drive removed after the experiment");
        assert_eq!(hw.link.sent.last(), Some(&BoardMessage::Identified(report)));
        // Every sample and every progress report fed the watchdog.
        assert!(
            hw.watchdog.0 > (SAFETY_SAMPLES + SAMPLES) as u32 + progress_count(&hw.link.sent) - 8
        );
        // The next power-up finds the parameters and runs no experiment.
        let mut service = Service::new(&mut store, LIMITS);
        hw.link.sent.clear();
        assert_eq!(service.boot(&mut hw), Boot::InService(report));
        assert!(hw.link.sent.is_empty());
        assert_eq!(hw.params.1, 1, "stored once");
    }

    #[test]
    fn a_motor_without_coulomb_friction_commissions_with_none() {
        let mut store = RecordStore::<SAMPLES>::new();
        let mut service = Service::new(&mut store, LIMITS);
        let mut hw = hardware(plant_with_friction(0.0));
        let report = service.commission(1, &mut hw).expect("commissioned");
        let friction = report.friction.expect("commissioning identifies friction");
        // Within three standard deviations of none, and under 1 % of the stall torque.
        assert!(friction.value <= 3.0 * friction.std, "tc {friction:?}");
        assert!(
            friction.value < 0.01 * 0.1604 * 50.0 / 3.412,
            "tc {friction:?}"
        );
        assert!(
            (report.params[3] / 0.00267 - 1.0).abs() < 0.03,
            "{report:?}"
        );
    }

    #[test]
    fn the_experiment_ends_with_a_coast_down_in_which_friction_alone_slows_the_shaft() {
        let (n, dt, volts) = (SAMPLES, 0.01, LIMITS.voltage);
        let coast = coast_start(n);
        assert_eq!(coast, 1500);
        let inputs: Vec<Bridge> = (0..n)
            .map(|k| commissioning_input(k, n, dt, volts))
            .collect();
        assert_eq!(inputs[0], Bridge::Drive(0.5 * volts));
        assert_eq!(inputs[700], Bridge::Drive(volts));
        assert_eq!(inputs[coast - 1], Bridge::Drive(0.25 * volts));
        assert!(inputs[coast..].iter().all(|b| *b == Bridge::Open));
        // Run it on a noise-free plant: in the coast-down no current flows and the speed
        // follows seed Eq. 4 with i = 0, w(t) = (w0 + tc/B) e^(-B t / J) - tc/B.
        let p = crate::device::plant::demo_motor();
        let mut plant = SimulatedPlant::new(&p, dt, 0.0, 0.0, 1).unwrap();
        let samples: Vec<Sample> = inputs.iter().map(|b| plant.apply(*b)).collect();
        let w0 = samples[coast].omega;
        assert!(w0 > 50.0, "turning when the bridge opens: {w0}");
        let (j, b, tc) = (0.0424f32, 0.00267f32, DEMO_FRICTION);
        for (m, s) in samples[coast + 1..].iter().enumerate() {
            let t = (m + 1) as f32 * dt;
            let want = (w0 + tc / b) * (-b * t / j).exp() - tc / b;
            assert!(
                (s.omega - want).abs() < 1e-3 * w0,
                "{t} s: {} vs {want}",
                s.omega
            );
            assert_eq!(s.current, 0.0);
        }
    }

    #[test]
    fn a_noise_free_commissioning_record_is_the_models_own_simulation_bit_for_bit() {
        // The plant and the fit open the bridge at the same sample: the true parameters
        // reproduce every reading exactly, so a coast-down one step early or late would show.
        let (n, truth) = (SAMPLES, crate::device::plant::demo_motor());
        let data = crate::testkit::Owned::commissioning(&truth, n, 0.01, LIMITS.voltage);
        let record = data.record(true, false);
        assert_eq!(record.coast_from, Some(coast_start(n)));
        let (w, i) = (&data.omega, &data.current);
        let (mut sim_w, mut sim_i) = (vec![0.0f32; n], vec![0.0f32; n]);
        crate::model::sim::simulate(
            &truth,
            &record,
            crate::model::sim::InitialState::REST,
            false,
            &mut sim_w,
            &mut sim_i,
        )
        .unwrap();
        assert_eq!(&sim_w, w);
        assert_eq!(&sim_i, i);
        let cost = crate::fit::objective::Objective::new(&[record])
            .unwrap()
            .cost(&truth)
            .unwrap();
        assert_eq!(cost.sse, 0.0);
        // The same record read as if the bridge had opened one sample later does not fit.
        let late = Record {
            coast_from: Some(coast_start(n) + 1),
            ..record
        };
        let late = [late];
        let objective = crate::fit::objective::Objective::new(&late).unwrap();
        assert!(objective.cost(&truth).unwrap().sse > 0.0);
    }

    #[test]
    fn a_current_sensor_offset_fails_the_safety_check_before_any_voltage() {
        let mut store = RecordStore::<SAMPLES>::new();
        let mut service = Service::new(&mut store, LIMITS);
        let mut plant = seed_plant();
        plant.offset.current = 2.0;
        let mut hw = hardware(plant);
        let end = JobEnd::Refused(Refusal::SensorFault);
        assert_eq!(service.boot(&mut hw), Boot::NotCommissioned(end));
        assert_eq!(hw.params.0, None);
        assert_eq!(hw.drive.stopped, 1);
        assert_eq!(
            hw.link.sent,
            vec![BoardMessage::Refused(Refusal::SensorFault)]
        );
    }

    #[test]
    fn a_motor_that_never_comes_to_rest_is_not_driven() {
        let mut store = RecordStore::<SAMPLES>::new();
        let mut service = Service::new(&mut store, LIMITS);
        let mut plant = seed_plant();
        plant.offset.omega = 50.0;
        let mut hw = hardware(plant);
        let end = JobEnd::Refused(Refusal::NotAtRest);
        assert_eq!(service.boot(&mut hw), Boot::NotCommissioned(end));
        assert_eq!(hw.params.0, None);
    }

    #[test]
    fn commissioning_again_waits_for_the_motor_to_stop_turning() {
        let mut store = RecordStore::<SAMPLES>::new();
        let mut service = Service::new(&mut store, LIMITS);
        let mut hw = hardware(seed_plant());
        let first = service.commission(2, &mut hw).expect("first commissioning");
        // The experiment ends at a quarter of the voltage: the motor still turns.
        let second = service
            .commission(2, &mut hw)
            .expect("second commissioning");
        for (a, b) in first.params.iter().zip(second.params) {
            assert!((a / b - 1.0).abs() < 0.03, "{a} vs {b}");
        }
    }

    #[test]
    fn a_current_trip_stops_the_drive_and_stores_nothing() {
        let mut store = RecordStore::<SAMPLES>::new();
        // The seed motor draws 50 V / 3.412 Ohm = 14.7 A at the step: a 5 A limit trips.
        let limits = Limits {
            current: 5.0,
            ..LIMITS
        };
        let mut service = Service::new(&mut store, limits);
        let mut hw = hardware(seed_plant());
        let end = JobEnd::Refused(Refusal::Trip);
        assert_eq!(service.boot(&mut hw), Boot::NotCommissioned(end));
        assert_eq!(hw.params.0, None);
        assert_eq!(hw.drive.stopped, 1);
        assert_eq!(
            hw.link.sent.last(),
            Some(&BoardMessage::Refused(Refusal::Trip))
        );
    }

    #[test]
    fn abort_during_identification_stores_nothing_and_requests_meanwhile_are_busy() {
        let mut store = RecordStore::<SAMPLES>::new();
        let mut service = Service::new(&mut store, LIMITS);
        let mut hw = hardware(seed_plant());
        // Polls 1..=8 fall in the experiment (every 256 samples), later ones in the fit: the
        // hello comes at the fit's first poll, the abort at its second.
        let hello = HostMessage::Hello {
            version: PROTOCOL_VERSION,
        };
        hw.link.incoming.push_back((8, hello));
        hw.link.incoming.push_back((9, HostMessage::Abort));
        assert_eq!(
            service.boot(&mut hw),
            Boot::NotCommissioned(JobEnd::Aborted)
        );
        assert_eq!(hw.params.0, None);
        assert!(hw.link.sent.contains(&BoardMessage::Refused(Refusal::Busy)));
        assert_eq!(hw.link.sent.last(), Some(&BoardMessage::Aborted));
        assert!(hw.link.sent.iter().any(|m| matches!(
            m,
            BoardMessage::Progress {
                stage: JobStage::Search | JobStage::Refine,
                ..
            }
        )));
    }

    #[test]
    fn requests_need_a_session_of_the_same_version() {
        let mut store = RecordStore::<SAMPLES>::new();
        let mut service = Service::new(&mut store, LIMITS);
        let mut hw = hardware(seed_plant());
        service.handle(HostMessage::ReadParams, &mut hw);
        let hello = |version| HostMessage::Hello { version };
        service.handle(hello(PROTOCOL_VERSION + 1), &mut hw);
        service.handle(HostMessage::ReadParams, &mut hw);
        service.handle(hello(PROTOCOL_VERSION), &mut hw);
        service.handle(HostMessage::ReadParams, &mut hw);
        assert_eq!(
            hw.link.sent,
            vec![
                BoardMessage::Refused(Refusal::NoSession),
                BoardMessage::Refused(Refusal::VersionMismatch {
                    board: PROTOCOL_VERSION
                }),
                BoardMessage::Refused(Refusal::NoSession),
                BoardMessage::Hello {
                    version: PROTOCOL_VERSION,
                    max_samples: SAMPLES as u32
                },
                BoardMessage::Params(None),
            ]
        );
    }
}
