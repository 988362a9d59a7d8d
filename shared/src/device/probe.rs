//! Commissioning's probe: what the board measures of an unknown motor before it designs the
//! experiment, each stage bounded in time and watched against the limits at every sample
//! (the [`Bench`]), in the order drive calibrations use (measure before exciting):
//!
//! 1. [`rest_and_offset`] ([`crate::device::rest`]): at 0 V, wait for the shaft and its
//!    current to stand still, then read the current sensor's offset (subtracted from then
//!    on) and the sensors' noise;
//! 2. [`ramp`]: the voltage raised from 0 until the current reaches a calibration current,
//!    or the shaft breaks away (the break-away voltage), or the voltage limit;
//! 3. [`electrical_step`]: a voltage step at standstill, sampled at the drive's rate:
//!    Ra = V / i (the current's plateau, paper Eq. 1 with ω = 0 and di/dt = 0) and La/Ra
//!    (the time to 63 % of it);
//! 4. [`mechanical_step`]: a step at the largest voltage the current limit allows, watched
//!    until the speed settles, nears the speed limit (the bridge's input then changes), or
//!    the stage's share of the budget ends: Kv from paper Eq. 1 in the steady state,
//!    Kv = (V - Ra i) / ω, and the mechanical time scale.
//!
//! Each stage has a frame of its own (`#[inline(never)]`): only one stage's traces are on
//! the board's stack at a time.
//!
//! The estimates are rough (tens of per cent); they size the experiment
//! ([`crate::device::design`]). A motor that cannot be commissioned within the limits is
//! refused here with its reason, before anything trips.

use crate::device::bench::Bench;
use crate::device::hardware::{Bridge, Drive, Link, Watchdog};
use crate::device::job::JobEnd;
use crate::device::rest::{quiet, rest_and_offset, Rest, QUIET_BUDGET};
use crate::device::trace::Trace;
use crate::wire::protocol::Refusal;

/// The ramp's calibration current (share of the current limit).
const CALIBRATION_CURRENT: f32 = 0.25;
/// Time the ramp takes from 0 to the voltage limit [s].
const RAMP_SECONDS: f32 = 2.0;
/// Share of the speed limit at which the mechanical step stops driving.
pub const SPEED_SHARE: f32 = 0.7;
/// Share of the current limit that the mechanical step's start current may reach.
const STEP_CURRENT: f32 = 0.6;
/// Points of a probe's traces.
const TRACE: usize = 128;
/// Share of the budget the mechanical step may take at most (where the shaft has not moved
/// by [`MOVING_BUDGET`]).
const MECHANICAL_BUDGET: f32 = 0.3;
/// Share of the budget the mechanical step takes at most once the shaft has moved: a slow
/// motor's step, which does not settle within it, leaves the rest to the slow record (on
/// the MCU table's motor 240, τm 104 s in a 60 s budget, the slow record 14.4 → 19.2 s and
/// the commissioning fit 366.7 → 129.3 M instructions; docs/measurements/commissioning.md).
/// A shaft not turning beyond its rest noise by then is watched to [`MECHANICAL_BUDGET`],
/// as before (refused for no motion only if it never does).
const MOVING_BUDGET: f32 = 0.2;
/// Share of the budget kept for the experiment's records when the mechanical step starts.
const RECORDS_BUDGET: f32 = 0.5;
/// The mechanical step's Kv when its back-EMF `V - Ra i` is not above zero: not measured
/// ([`crate::device::design`] refuses the motor with [`Refusal::NoBackEmf`]) [V s/rad].
pub const KV_FLOOR: f32 = 1e-6;
/// A first-order response's rise at its time constant, 1 - 1/e.
const RISE_AT_TAU: f32 = 1.0 - 1.0 / core::f32::consts::E;

/// What the four stages measured, and the time they took.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Probed {
    /// Stage 1.
    pub rest: Rest,
    /// Stage 2.
    pub ramp: Ramp,
    /// Stage 3.
    pub electrical: Electrical,
    /// Stage 4.
    pub mechanical: Mechanical,
    /// Time the probe took [s].
    pub seconds: f32,
}

/// The four stages in turn; the current sensor's offset is subtracted from stage 1 on. The
/// mechanical step takes at most [`MOVING_BUDGET`] of the budget where it has moved the
/// shaft by then, else [`MECHANICAL_BUDGET`], and leaves [`RECORDS_BUDGET`] of it to the
/// records.
pub fn probe<D: Drive, L: Link, W: Watchdog>(bench: &mut Bench<D, L, W>) -> Result<Probed, JobEnd> {
    let budget = bench.limits.budget;
    let rest = rest_and_offset(bench)?;
    bench.current_offset = rest.current_offset;
    let ramp = ramp(bench, &rest)?;
    let electrical = electrical_step(bench, &rest, &ramp)?;
    let floor = ramp.breakaway.unwrap_or(0.0);
    let most = (MECHANICAL_BUDGET * budget).min(bench.left() - RECORDS_BUDGET * budget);
    let once_moving = (MOVING_BUDGET * budget).min(most);
    let mechanical = mechanical_step(bench, &rest, &electrical, floor, (once_moving, most))?;
    Ok(Probed {
        rest,
        ramp,
        electrical,
        mechanical,
        seconds: bench.seconds(),
    })
}

/// The ramp of stage 2.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ramp {
    /// Voltage at which the shaft broke away, if it did [V].
    pub breakaway: Option<f32>,
    /// Voltage at the ramp's end [V].
    pub volts: f32,
    /// Current at the ramp's end [A].
    pub current: f32,
}

/// Stage 2: the voltage raised from 0 to the limit over [`RAMP_SECONDS`] (a twentieth of the
/// budget at most), until the shaft turns, the current reaches [`CALIBRATION_CURRENT`] of its
/// limit, or the voltage its limit; then 0 V until the current is gone.
#[inline(never)]
pub fn ramp<D: Drive, L: Link, W: Watchdog>(
    bench: &mut Bench<D, L, W>,
    rest: &Rest,
) -> Result<Ramp, JobEnd> {
    let limits = bench.limits;
    let rate = limits.voltage / RAMP_SECONDS.min(limits.budget / 20.0);
    let moving = rest.motion(limits.speed);
    let (mut speed, mut k) = (0.0f32, 0u32);
    let end = loop {
        let v = (rate * k as f32 * bench.dt()).min(limits.voltage);
        let s = bench.apply(Bridge::Drive(v))?;
        k += 1;
        // A short mean, so that one noisy reading is not motion.
        speed = 0.75 * speed + 0.25 * s.omega;
        if speed.abs() > moving {
            break Ramp {
                breakaway: Some(v),
                volts: v,
                current: s.current,
            };
        }
        if s.current >= CALIBRATION_CURRENT * limits.current || v >= limits.voltage {
            break Ramp {
                breakaway: None,
                volts: v,
                current: s.current,
            };
        }
    };
    quiet(bench, rest, QUIET_BUDGET * limits.budget)?;
    Ok(end)
}

/// The electrical step of stage 3.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Electrical {
    /// Armature resistance [ohm].
    pub ra: f32,
    /// Electrical time constant La/Ra [s].
    pub tau_e: f32,
}

/// Stage 3: a voltage step from standstill, sampled until the current stops rising (no
/// rise over the last half of the step) or a tenth of the budget; the plateau gives Ra and the time to
/// 63 % of it La/Ra. The step's voltage gives about a tenth of the current limit by the
/// ramp's end (at least the ramp's end voltage); a current beyond [`crate::device::bench::GUARD`]
/// of its limit opens the bridge and the step is tried again at a third of the voltage.
#[inline(never)]
pub fn electrical_step<D: Drive, L: Link, W: Watchdog>(
    bench: &mut Bench<D, L, W>,
    rest: &Rest,
    ramp: &Ramp,
) -> Result<Electrical, JobEnd> {
    let limits = bench.limits;
    let floor = rest.no_current(limits.current);
    let rough_ra = ramp.volts / ramp.current.max(floor);
    let mut v = (0.1 * limits.current * rough_ra)
        .max(ramp.volts)
        .min(limits.voltage);
    let most = (0.1 * limits.budget / bench.dt()) as u32;
    for _ in 0..3 {
        let mut trace = Trace::<TRACE>::new();
        // Rises counted from the first reading on: a heavy shaft may still turn slowly as the
        // step starts, its braking current below zero, and a climb counted from 0 A was no
        // rise at all (the step ended at once and Ra came out tens of times too high).
        let (mut rising_from, mut last_rise, mut k) = (f32::NEG_INFINITY, 0u32, 0u32);
        let (mut first, mut guarded) = (f32::NAN, false);
        while k < most {
            let Some(s) = bench.guarded(Bridge::Drive(v), 1.0)? else {
                guarded = true;
                break;
            };
            k += 1;
            trace.push(s.current);
            if k == 1 {
                first = s.current;
            }
            if s.current > rising_from + (3.0 * rest.sigma_current).max(0.005 * rising_from) {
                (rising_from, last_rise) = (s.current, k);
            }
            // No rise over the last half of the step: the plateau (a slow rise that the
            // ADC's counts show only now and then keeps it going). Judged only once the
            // current has risen by more than the no-current level from where it started:
            // under a long La/Ra the first rise above the noise takes hundreds of samples,
            // and a step judged before it ended at 35 samples with Ra thirty times too high.
            if k >= 32 && rising_from - first > floor && k - last_rise > k / 2 + 16 {
                break;
            }
        }
        quiet(bench, rest, QUIET_BUDGET * limits.budget)?;
        if guarded {
            v /= 3.0;
            continue;
        }
        let plateau = trace.max().max(floor);
        let k63 = trace.first_reaching(RISE_AT_TAU * plateau).unwrap_or(0.0);
        return Ok(Electrical {
            ra: v / plateau,
            tau_e: (k63 * bench.dt()).max(0.5 * bench.dt()),
        });
    }
    Err(JobEnd::Refused(Refusal::Trip))
}

/// The mechanical step of stage 4.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mechanical {
    /// Back-EMF constant [V s/rad].
    pub kv: f32,
    /// Mechanical time scale [s]: J Ra / Kv² with J from the mean acceleration under the
    /// mean current, or the time to 63 % of the settled speed if longer.
    pub tau_m: f32,
    /// Largest speed over the settled (or last) speed (above 1 for an overshoot).
    pub overshoot: f32,
    /// Current at the step's end [A] (with the speed settled: the friction's, Kv i = B ω + tc).
    pub current: f32,
    /// The current the back-EMF takes away at the step's end [A]: (V - Ra i) / Ra = Kv ω / Ra
    /// (paper Eq. 1 in the steady state), the stall current less the current read. Where it
    /// is within a few counts of the current reading, the records fix Kv only through it,
    /// and J, B and friction, known relative to Kv from the speed, with it
    /// ([`crate::device::unpinned::Unpinned::BackEmfBelowResolution`]).
    pub back_emf_current: f32,
    /// The speed settled.
    pub settled: bool,
    /// The step's voltage [V].
    pub volts: f32,
    /// The highest speed the step reached [rad/s].
    pub top: f32,
    /// The step's duration [s].
    pub seconds: f32,
}

/// Stage 4: a voltage step at the largest voltage the current limit allows
/// ([`STEP_CURRENT`] of it at standstill, by the stage-3 Ra), watched until the speed
/// settles (it rose under 3 % over the last third of the step), reaches [`SPEED_SHARE`] of
/// its limit, or its time passes: `seconds_moving` where the shaft has turned beyond its
/// rest noise by then (its highest reading, as the refusal judges it: a shaft still
/// coasting from the stages before counts), else `seconds`. A shaft that never turns is
/// refused ([`Refusal::NoMotion`]). The bridge stays driven at the step's voltage at its
/// end; the experiment waits for the shaft to stand still before its records.
#[inline(never)]
pub fn mechanical_step<D: Drive, L: Link, W: Watchdog>(
    bench: &mut Bench<D, L, W>,
    rest: &Rest,
    electrical: &Electrical,
    floor: f32,
    (seconds_moving, seconds): (f32, f32),
) -> Result<Mechanical, JobEnd> {
    let limits = bench.limits;
    let ra = electrical.ra;
    let mut v = (STEP_CURRENT * limits.current * ra).min(limits.voltage);
    let moving = rest.motion(limits.speed);
    let most = ((seconds / bench.dt()) as u32).max(64);
    let most_moving = ((seconds_moving / bench.dt()) as u32).max(64);
    for _ in 0..3 {
        let mut speed = Trace::<TRACE>::new();
        let mut current = Trace::<TRACE>::new();
        let (mut k, mut guarded, mut settled) = (0u32, false, false);
        let (mut top, mut start) = (0.0f32, None);
        // The step's time: `most_moving` samples where the shaft has turned beyond its rest
        // noise by then, else `most`, as before: a shaft the refusal below would call
        // standing at `most_moving` is watched as long as it was.
        let mut window = most_moving;
        while k < window {
            let Some(s) = bench.guarded(Bridge::Drive(v), 1.0)? else {
                guarded = true;
                break;
            };
            k += 1;
            let w0 = *start.get_or_insert(s.omega);
            speed.push(s.omega);
            current.push(s.current);
            top = top.max(s.omega);
            if s.omega >= SPEED_SHARE * limits.speed {
                break;
            }
            if k == most_moving && top <= moving {
                window = most;
            }
            if k >= 64 && k % 32 == 0 {
                // The shaft may still turn from the stages before: the rise counts from
                // where it started.
                let (now, then) = (speed.last(), speed.at_sample(2 * k / 3));
                if now - w0 > moving && now - then <= 0.03 * (now - w0) {
                    settled = true;
                    break;
                }
            }
        }
        if guarded {
            quiet(bench, rest, QUIET_BUDGET * limits.budget)?;
            v = floor + 0.5 * (v - floor);
            continue;
        }
        if top <= moving {
            return Err(JobEnd::Refused(Refusal::NoMotion));
        }
        let (w_end, i_end) = (speed.last(), current.last());
        // Paper Eq. 1 in the steady state: the back-EMF is what the resistance leaves.
        let back_emf = v - ra * i_end;
        let kv = (back_emf / w_end).max(KV_FLOOR);
        let t = k as f32 * bench.dt();
        let w0 = start.unwrap_or(0.0);
        let tau_m = match settled {
            true => speed.first_reaching(w0 + RISE_AT_TAU * (w_end - w0)),
            false => None,
        };
        // J from the mean acceleration under the mean torque (friction left out: J and the
        // time scale come out long, which errs towards a longer record); the longer of that
        // and the time to 63 %.
        let accelerating = match settled {
            // Settled: the end current is the friction's; the rest accelerated the shaft.
            true => current.mean() - i_end,
            false => current.mean(),
        };
        let j = kv * accelerating.max(0.0) / ((w_end - w0).max(moving) / t);
        let by_inertia = j * ra / (kv * kv);
        let tau_m = tau_m.map_or(by_inertia, |k63| by_inertia.max(k63 * bench.dt()));
        return Ok(Mechanical {
            kv,
            tau_m: tau_m.max(bench.dt()),
            overshoot: (top / w_end).max(1.0),
            current: i_end,
            back_emf_current: (back_emf / ra).max(0.0),
            settled,
            volts: v,
            top,
            seconds: t,
        });
    }
    Err(JobEnd::Refused(Refusal::Trip))
}
