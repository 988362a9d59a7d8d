//! Self-commissioning's experiment, from an unknown motor to the records the board fits:
//! the probe ([`crate::device::probe`]) measures the motor within the limits and refuses
//! what cannot be commissioned within them; the experiment is designed from it
//! ([`crate::device::design`]); its two records are recorded
//! ([`crate::device::experiment`]); the problem the board then solves is
//! [`commissioning_spec`].

use crate::device::bench::{Bench, GUARD};
use crate::device::design::{design, Design};
use crate::device::experiment::{coast_start, fast_input, record, slow_input};
use crate::device::hardware::{Drive, Link, Watchdog};
use crate::device::job::JobEnd;
use crate::device::offset::coast_offset;
use crate::device::probe::{probe, Probed};
use crate::device::record_store::RecordStore;
use crate::device::rest::{quiet, QUIET_BUDGET};
use crate::fit::space::ProblemSpec;
use crate::param_id::ParamId;
use crate::wire::limits::Limits;
use crate::wire::protocol::{BoardMessage, JobStage, Plan, Refusal};

/// The probe, the design and the records of a commissioning, into `store`, within `limits`:
/// the plan is sent on the link before the records (and returned). A trip, a sensor fault,
/// a motor the probe refuses, or an abort stop the drive and end it (the caller reports it).
/// The drive is stopped at the end in every case. With `averaged`, each record sample is the
/// mean of the drive's readings over its step ([`crate::model::step_mean`]).
pub fn run_experiment<const N: usize>(
    store: &mut RecordStore<N>,
    limits: &Limits,
    averaged: bool,
    link: &mut impl Link,
    drive: &mut impl Drive,
    watchdog: &mut impl Watchdog,
) -> Result<Plan, JobEnd> {
    if !limits.usable() {
        return Err(JobEnd::Refused(Refusal::BadLimits));
    }
    let mut bench = Bench::new(drive, link, watchdog, *limits);
    bench.averaged = averaged;
    let result = probe_and_record(&mut bench, store);
    drive.stop();
    result
}

fn probe_and_record<const N: usize, D: Drive, L: Link, W: Watchdog>(
    bench: &mut Bench<D, L, W>,
    store: &mut RecordStore<N>,
) -> Result<Plan, JobEnd> {
    let probed = probe(bench)?;
    let d = design(&bench.limits, bench.dt(), N, &probed).map_err(JobEnd::Refused)?;
    let plan = plan(&d, bench.dt(), &probed);
    bench.link().send(&BoardMessage::Planned(plan));
    bench.enter(JobStage::Experiment);
    store.clear(true);
    record_designed(bench, store, &d, &probed)?;
    let residual = coast_offset(&store.records(), &probed.rest, probed.electrical.tau_e);
    store.shift_current(residual);
    Ok(plan)
}

/// The two records of design `d`, each from rest (the shaft quiet): the slow one, then the
/// fast one. A guard (a current or speed nearing its limit) ends it as a trip. (A slow
/// record that took over where the probe's mechanical step ended started from a speed not
/// quite settled; the fit took its current for the equilibrium's and biased B by up to 6 %
/// at 20 σ on the reference plant's 10-ohm corner.)
fn record_designed<const N: usize, D: Drive, L: Link, W: Watchdog>(
    bench: &mut Bench<D, L, W>,
    store: &mut RecordStore<N>,
    d: &Design,
    probed: &Probed,
) -> Result<(), JobEnd> {
    // From rest: a record that starts where the probe's mechanical step ended starts from a
    // speed not quite settled, whose current the fit would take for the equilibrium's.
    quiet(bench, &probed.rest, QUIET_BUDGET * bench.limits.budget)?;
    let n = d.slow.samples;
    let slow = record(bench, store, d.slow, GUARD, Some(coast_start(n)), |k| {
        slow_input(k, n, d.volts)
    })?;
    quiet(bench, &probed.rest, QUIET_BUDGET * bench.limits.budget)?;
    let n = d.fast.samples;
    let fast = slow
        && record(bench, store, d.fast, GUARD, None, |k| {
            fast_input(k, n, d.volts)
        })?;
    match fast {
        true => Ok(()),
        false => Err(JobEnd::Refused(Refusal::Trip)),
    }
}

/// The plan sent to the host: what the probe measured and the records designed from it.
fn plan(d: &Design, dt: f32, p: &Probed) -> Plan {
    let drive_samples = d.slow.drive_samples() + d.fast.drive_samples();
    Plan {
        current_offset: p.rest.current_offset,
        breakaway_volts: p.ramp.breakaway.unwrap_or(f32::NAN),
        ra: p.electrical.ra,
        tau_e: p.electrical.tau_e,
        kv: p.mechanical.kv,
        tau_m: p.mechanical.tau_m,
        back_emf_current: p.mechanical.back_emf_current,
        volts: d.volts,
        fast_dt: d.fast.dt(dt),
        fast_samples: d.fast.samples as u16,
        slow_dt: d.slow.dt(dt),
        slow_samples: d.slow.samples as u16,
        probe_seconds: p.seconds,
        planned_seconds: p.seconds + drive_samples as f32 * dt,
    }
}

/// The problem a board solves when it commissions itself: the five motor parameters within
/// the paper's Table 1 and Coulomb friction `tc` (which the coast-down pins) up to the largest
/// torque the drive can apply by the probe's Kv (1.5 Kv I_max, so that a shaft the drive
/// turns always lies inside; at least the catalogue's bound), the other effects left out.
pub fn commissioning_spec(plan: &Plan, limits: &Limits) -> ProblemSpec {
    let mut spec = ProblemSpec::default();
    spec.free(ParamId::Tc);
    let (lo, hi) = ParamId::Tc.default_bounds();
    let drive_torque = 1.5 * plan.kv * limits.current;
    if drive_torque > hi {
        // Finite and above a valid bound: it is a valid bound.
        let _ = spec.set_bounds(ParamId::Tc, lo, drive_torque);
    }
    spec
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::hardware::{Bridge, Sample};
    use crate::device::plant::{SimulatedPlant, DEMO_FRICTION};
    use crate::model::record::Record;

    const SAMPLES: usize = 2000;
    const VOLTAGE: f32 = 50.0;

    #[test]
    fn the_slow_record_ends_with_a_coast_down_in_which_friction_alone_slows_the_shaft() {
        let (n, dt, volts) = (SAMPLES, 0.01, VOLTAGE);
        let coast = coast_start(n);
        let inputs: Vec<Bridge> = (0..n).map(|k| slow_input(k, n, volts)).collect();
        // Run it on a noise-free plant: in the coast-down no current flows and the speed
        // follows paper Eq. 4 with i = 0, w(t) = (w0 + tc/B) e^(-B t / J) - tc/B.
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
    fn a_noise_free_slow_record_is_the_models_own_simulation_bit_for_bit() {
        // The plant and the fit open the bridge at the same sample: the true parameters
        // reproduce every reading exactly, so a coast-down one step early or late would show.
        let (n, truth) = (SAMPLES, crate::device::plant::demo_motor());
        let data = crate::testkit::Owned::commissioning(&truth, n, 0.01, VOLTAGE);
        let record = data.record(true, false);
        assert_eq!(record.coast_from, Some(coast_start(n)));
        let (w, i) = (&data.omega, &data.current);
        let (mut sim_w, mut sim_i) = (vec![0.0f32; n], vec![0.0f32; n]);
        crate::model::record::simulate(
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
}
