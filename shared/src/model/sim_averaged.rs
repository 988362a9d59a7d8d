//! Records of averaged readings ([`crate::model::record::Record::averaged`]): a simulation
//! that reads, for each sample, the mean of the drive's readings over the step that ends at
//! it ([`crate::model::step_mean`]), exactly while the shaft turns or stands over the whole
//! step, and by simulating the step again in the drive's steps where it stops, reverses or
//! breaks away.

use super::{sign, InitialState, MeasuredTacho, Reading, Simulator, StepInput};
use crate::capacity::FULL;
use crate::error::Error;
use crate::model::compensated::Compensated;
use crate::model::discretise::Discrete;
use crate::model::effects::current_offset;
use crate::model::params::ModelParams;
use crate::model::record::Record;
use crate::model::step_mean::StepMean;
use crate::param_id::ParamId;

/// Whether `p` and `q` hold the same motor (Ra, La, J, B, Kv, to the bit): the same
/// coefficients ([`Discrete::new`], [`StepMean::new`]).
fn same_motor(p: &ModelParams, q: &ModelParams) -> bool {
    ParamId::MOTOR
        .iter()
        .all(|&id| p.get(id).to_bits() == q.get(id).to_bits())
}

/// Readings averaged over each step ([`crate::model::step_mean`]): the mean's coefficients
/// and the mean over the last step (the reading at the start before the first).
#[derive(Clone, Copy, Debug)]
pub(super) struct Averaged {
    pub(super) coeffs: StepMean,
    /// Drive samples per step.
    pub(super) m: u32,
    pub(super) last: Reading,
    /// The motor's coefficients over one drive sample (a share `1 / m` of the record's
    /// step) for the steps a stop or a break-away is simulated in
    /// ([`Simulator::average_over_step`]): made at the first such step, then kept (a
    /// discretisation in soft-float f64 on a board, once instead of at every event).
    pub(super) drive: Option<Discrete>,
}

impl Simulator {
    /// A simulation of record `r` from `init`: its readings at the sample instants, or, for
    /// a record of readings averaged over each step ([`Record::averaged`] drive samples),
    /// their means ([`Simulator::sample`]).
    #[inline(always)]
    pub fn for_record(p: &ModelParams, r: &Record, init: InitialState) -> Result<Self, Error> {
        Simulator::for_record_like(p, r, init, None)
    }

    /// [`Simulator::for_record`], bit for bit, with the motor's coefficients taken from
    /// `like` (a simulator of the same record for the set `like.0`) when `p`'s motor (Ra,
    /// La, J, B, Kv) is that set's: a Jacobian's column of an effect's parameter, or a
    /// record's initial speed shifted, needs no discretisation of its own (in soft-float
    /// f64 on a board, where they were most of a fit's instructions:
    /// docs/measurements/commissioning.md).
    #[inline(always)]
    pub fn for_record_like(
        p: &ModelParams,
        r: &Record,
        init: InitialState,
        like: Option<(&ModelParams, &Simulator)>,
    ) -> Result<Self, Error> {
        let like = like
            .filter(|(q, s)| s.dt == r.dt && same_motor(p, q))
            .map(|(_, s)| s);
        let disc = like.map(|s| s.disc);
        match r.averaged > 1 {
            // The mean's coefficients made here, on the caller's frame, not beneath the
            // simulator's own (their f64 matrix functions are the deepest of a board's
            // calls: docs/measurements/footprint.md).
            true => {
                let kept = like.and_then(|s| s.averaged).filter(|a| a.m == r.averaged);
                let coeffs = match kept {
                    Some(a) => a.coeffs,
                    None => StepMean::new(p, r.dt, r.averaged),
                };
                Simulator::averaged(p, r, init, coeffs, disc)
            }
            false => Simulator::with_motor(p, r.dt, init, disc),
        }
    }

    /// [`Simulator::for_record`] of averaged readings. Exact for the linear motor and
    /// Coulomb friction (see [`Simulator::average_over_step`]): any other effect would be
    /// held at an instant. `coeffs` are the mean's ([`StepMean::new`] of `p`, `r.dt` and
    /// `r.averaged`), `disc` the motor's when known. (Out of line: the fit's frames stay
    /// small.)
    #[inline(never)]
    fn averaged(
        p: &ModelParams,
        r: &Record,
        init: InitialState,
        coeffs: StepMean,
        disc: Option<Discrete>,
    ) -> Result<Self, Error> {
        let mut s = Simulator::with_motor(p, r.dt, init, disc)?;
        if !s.friction_only || s.delayed {
            return Err(Error::AveragedReadingsNotModelled);
        }
        s.averaged = Some(Averaged {
            coeffs,
            m: r.averaged,
            last: Reading {
                omega: 0.0,
                current: 0.0,
            },
            drive: None,
        });
        s.reset(init);
        if init.omega != 0.0 {
            s.start_after_quiet_step(r.load_at(0));
        }
        Ok(s)
    }

    /// The load `tl` and Coulomb friction against a shaft turning at `w`, both held over a
    /// step (the linear mean's load, [`StepMean`]).
    fn load_while_turning(&self, tl: f32, w: f32) -> f32 {
        match self.friction {
            true => tl + self.effect(ParamId::Tc) * sign(w),
            false => tl,
        }
    }

    /// A record of averaged readings that starts in motion: its first sample is the mean
    /// over the step before it (the reading the simulator reset to), not the state at its
    /// start. That step held 0 V with the bridge closed (a board's records start after its
    /// quiet wait, [`crate::device::rest::quiet`]; docs/CONTRACTS.md), so the state at the
    /// start is the end of a step of the motor (paper Eq. 5) from the start whose mean
    /// ([`StepMean::start_of`]) is that reading; Coulomb friction a held load, as in
    /// [`Simulator::average_over_step`]. (A shaft braking from speed at 0 V changes its
    /// current within the step: taken for the state, the mean's lag left a current misfit
    /// decaying with La/Ra that pushed the fit to wide searches,
    /// docs/measurements/commissioning.md.)
    fn start_after_quiet_step(&mut self, tl: f32) {
        let (i, w) = (self.current.hi, self.omega.hi);
        let load = self.load_while_turning(tl, w);
        let Some(a) = &self.averaged else { return };
        let Some((i0, w0)) = a.coeffs.start_of((i, w), 0.0, load) else {
            return;
        };
        let (di, dw) = self.disc.increments(i0, w0, 0.0, load);
        self.current = Compensated::new(i0 + di);
        self.omega = Compensated::new(w0 + dw);
    }

    /// The mean `[i, w]` of `m` drive steps over the step just taken, from its start
    /// `(i0, w0, stuck)` (see [`Simulator::average_over_step`]).
    fn substepped_mean(&mut self, m: u32, start: (f32, f32, bool), v: f32, tl: f32) -> (f32, f32) {
        let (i0, w0, stuck) = start;
        let share = 1.0 / m as f32;
        let Some(disc) = self.drive_step(share) else {
            return (0.5 * (i0 + self.current.hi), 0.5 * (w0 + self.omega.hi));
        };
        let mut drive = self.clone();
        drive.averaged = None;
        (drive.disc, drive.dt) = (disc, self.dt * share);
        drive.current = Compensated::new(i0);
        drive.omega = Compensated::new(w0);
        drive.shaft_stuck = stuck;
        let (mut si, mut sw) = (0.0f32, 0.0f32);
        for _ in 0..m {
            drive.step(v, tl, None);
            (si, sw) = (si + drive.current.hi, sw + drive.omega.hi);
        }
        (si / m as f32, sw / m as f32)
    }

    /// The coefficients over one drive sample, a `share` of the record's step
    /// ([`Averaged::drive`], [`Discrete::over_share`]); None where they cannot be made.
    fn drive_step(&mut self, share: f32) -> Option<Discrete> {
        if let Some(drive) = self.averaged.as_ref().and_then(|a| a.drive) {
            return Some(drive);
        }
        let drive = self.disc.over_share(self.dt, self.kv, share).ok()?;
        if let Some(a) = &mut self.averaged {
            a.drive = Some(drive);
        }
        Some(drive)
    }

    /// What a record's sample reads after the steps so far: the reading now, or with
    /// `AVERAGED`, for averaged readings ([`Simulator::for_record`]), the mean over the
    /// last step ([`Simulator::apply_record`]). (A const parameter: the fit loops of
    /// records at instants keep their code, which a test per step slowed by a fifth.)
    #[inline(always)]
    pub fn sample<const AVERAGED: bool>(&self) -> Reading {
        match (AVERAGED, &self.averaged) {
            (true, Some(a)) => a.last,
            _ => self.reading(),
        }
    }

    /// [`Simulator::apply`], and with `AVERAGED` the mean of the readings over the step for
    /// averaged readings ([`Simulator::sample`]).
    #[inline(always)]
    pub fn apply_record<const AVERAGED: bool>(&mut self, input: &StepInput) {
        // (Readings at the instants on the averaged path, as a board's fit of them takes
        // it: the plain step, no frame of the mean's.)
        if !AVERAGED || self.averaged.is_none() {
            return self.apply(input);
        }
        if input.opens {
            self.open_circuit();
        }
        self.step_averaged(input.v, input.tl, input.measured);
    }

    /// Whether the loops over `records` take the path of averaged readings
    /// ([`Simulator::sample`] with `AVERAGED`): where a record holds them, and always on a
    /// board ([`crate::capacity::FULL`] off), whose build so holds one copy of the fit's
    /// loops (2.3 KB of flash less, at a test per sample).
    pub fn averaged_path(records: &[Record]) -> bool {
        !FULL || records.iter().any(|r| r.averaged > 1)
    }

    /// [`Simulator::step`] and the mean of the readings over it (averaged readings).
    #[inline(never)]
    fn step_averaged(&mut self, v: f32, tl: f32, measured: Option<MeasuredTacho>) {
        let start = (self.current.hi, self.omega.hi, self.shaft_stuck);
        self.friction_event = false;
        self.step(v, tl, measured);
        if let Some(a) = &self.averaged {
            let (coeffs, m) = (a.coeffs, a.m);
            self.average_over_step(&coeffs, m, start, v, tl);
        }
    }

    /// The mean of the readings over the step just taken from `(i0, w0, stuck)`, with `v`
    /// and `tl` held ([`StepMean`], `m` drive samples): exact while the shaft turns
    /// (Coulomb friction a held load, as in [`Simulator::step_friction`]) or stands (the
    /// rotor held) over the whole step, with the bridge open or closed. Over a step in which
    /// the shaft stops, reverses or breaks away, the step is simulated again in `m` steps
    /// of the drive's (its coefficients over that share, [`Discrete::over_share`]) and
    /// their readings averaged: one sample of a record, at a stop or a start, where a
    /// mean of the step's two ends would be off by a good part of the step's change.
    #[inline(never)]
    fn average_over_step(
        &mut self,
        c: &StepMean,
        m: u32,
        start: (f32, f32, bool),
        v: f32,
        tl: f32,
    ) {
        let (i0, w0, stuck) = start;
        // A stop or a break-away within the step, whatever the step's ends (a shaft may
        // stop and turn on, or break away and stick again, within one step).
        let event = self.friction_event;
        let through = !stuck && !self.shaft_stuck && !event;
        let held = stuck && self.shaft_stuck && !event;
        let (i, w) = match (through, held, self.open) {
            (true, _, open) => {
                let load = self.load_while_turning(tl, w0);
                match open {
                    true => (0.0, c.mechanical(w0, load)),
                    false => c.linear(i0, w0, v, load),
                }
            }
            (false, true, true) => (0.0, 0.0),
            (false, true, false) => (c.held_rotor(i0, v), 0.0),
            (false, false, _) => self.substepped_mean(m, start, v, tl),
        };
        let current = current_offset::reading(self.effect(ParamId::Io), i);
        if let Some(a) = &mut self.averaged {
            a.last = Reading { omega: w, current };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::record::Record;

    #[test]
    fn the_drive_step_is_made_at_the_first_stop_and_kept() {
        // The paper motor with Coulomb friction braking at 0 V from a slow turn, in
        // record steps of ten drive samples: it stops within a few steps. Before the stop
        // no drive step is made; at it, the one over a tenth of the record's step, and the
        // same one is what every later event uses.
        let p = ModelParams::PAPER_MOTOR.with(ParamId::Tc, 0.5);
        let (m, n) = (10u32, 40usize);
        let zeros = [0.0f32; 40];
        let r = Record {
            dt: 0.01,
            v: &zeros,
            omega: &zeros,
            current: Some(&zeros),
            load: None,
            coast_from: None,
            averaged: m,
        };
        let init = InitialState {
            current: 0.0,
            omega: 1.0,
        };
        let mut s = Simulator::for_record(&p, &r, init).unwrap();
        let drive = |s: &Simulator| s.averaged.as_ref().and_then(|a| a.drive);
        assert_eq!(drive(&s), None);
        let expected = s.disc.over_share(s.dt, s.kv, 1.0 / m as f32).unwrap();
        let mut stopped_at = None;
        for k in 0..n {
            s.apply_record::<true>(&r.step_input(k, false));
            if s.shaft_stuck && stopped_at.is_none() {
                stopped_at = Some(k);
            }
            assert_eq!(drive(&s).is_some(), stopped_at.is_some(), "step {k}");
        }
        assert!(stopped_at.is_some_and(|k| k > 0), "{stopped_at:?}");
        assert_eq!(drive(&s), Some(expected));
    }

    /// The readings of `s` over record `r`.
    fn readings(mut s: Simulator, r: &Record) -> [(u32, u32); 60] {
        let mut out = [(0, 0); 60];
        for (k, o) in out.iter_mut().enumerate() {
            let y = match r.averaged > 1 {
                true => s.sample::<true>(),
                false => s.sample::<false>(),
            };
            *o = (y.omega.to_bits(), y.current.to_bits());
            match r.averaged > 1 {
                true => s.apply_record::<true>(&r.step_input(k, false)),
                false => s.apply_record::<false>(&r.step_input(k, false)),
            }
        }
        out
    }

    #[test]
    fn a_simulator_like_another_of_the_same_motor_takes_its_coefficients_and_no_other() {
        // Voltage steps with stops and reversals against Coulomb friction, in records of
        // averaged and of instant readings. A set differing from `like`'s only in an
        // effect's parameter, or in its start, simulates bit for bit as one built anew; so
        // does one with another motor, which must not take `like`'s coefficients.
        let v: [f32; 60] = core::array::from_fn(|k| [6.0, 0.0, -4.0, 1.0][k / 15]);
        let zeros = [0.0f32; 60];
        let p = ModelParams::PAPER_MOTOR.with(ParamId::Tc, 0.05);
        let turning = InitialState {
            current: 0.0,
            omega: 3.0,
        };
        for m in [1, 10] {
            let r = Record {
                dt: 0.01,
                v: &v,
                omega: &zeros,
                current: Some(&zeros),
                load: None,
                coast_from: None,
                averaged: m,
            };
            let like = Simulator::for_record(&p, &r, InitialState::REST).unwrap();
            let others = [
                (p.with(ParamId::Tc, 0.06), InitialState::REST),
                (p, turning),
                (p.with(ParamId::B, 1.5 * p.get(ParamId::B)), turning),
                (
                    p.with(ParamId::Kv, 1.01 * p.get(ParamId::Kv)),
                    InitialState::REST,
                ),
            ];
            for (q, init) in others {
                let anew = Simulator::for_record(&q, &r, init).unwrap();
                let shared = Simulator::for_record_like(&q, &r, init, Some((&p, &like))).unwrap();
                assert_eq!(readings(shared, &r), readings(anew, &r), "m {m}, {q:?}");
            }
            // Taken, not rebuilt: coefficients swapped into `like` reach the simulator of
            // the same motor.
            let mut swapped = like.clone();
            let other = p.with(ParamId::J, 2.0 * p.get(ParamId::J));
            swapped.disc = Discrete::new(&other, r.dt).unwrap();
            let s = Simulator::for_record_like(&p, &r, turning, Some((&p, &swapped))).unwrap();
            assert_eq!(s.disc, swapped.disc);
            assert_ne!(s.disc, like.disc);
        }
    }
}
