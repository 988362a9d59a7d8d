//! Test support: synthetic records owned in vectors.

use crate::device::experiment::{coast_start, slow_input};
use crate::device::hardware::{Drive, Link};
use crate::device::plant::SimulatedPlant;
use crate::model::params::ModelParams;
use crate::model::profile::{Experiment, Profile};
use crate::model::record::Record;
use crate::model::synth::{synthesize, Buffers, Noise};
use crate::wire::protocol::{BoardMessage, HostMessage};
use std::vec::Vec;

/// A link to a host that sends nothing and reads nothing (device stages run alone).
pub struct SilentLink;

impl Link for SilentLink {
    fn send(&mut self, _msg: &BoardMessage) {}
    fn poll(&mut self) -> Option<HostMessage> {
        None
    }
}

pub struct Owned {
    pub dt: f32,
    pub v: Vec<f32>,
    pub tl: Vec<f32>,
    pub omega: Vec<f32>,
    pub current: Vec<f32>,
    pub coast_from: Option<usize>,
}

impl Owned {
    /// The paper's motor run through `profile` at 50 V for `n` samples of `dt`.
    pub fn paper_motor(profile: Profile, dt: f32, n: usize, noise: Noise, seed: u64) -> Owned {
        let exp = Experiment {
            profile,
            voltage: 50.0,
            duration: dt * n as f32,
            load_torque: 0.0,
        };
        Owned::new(&ModelParams::PAPER_MOTOR, exp, dt, n, noise, seed)
    }

    /// The paper's motor under voltage steps, 2,000 samples of 15 ms, with 0.5 rad/s of
    /// speed noise and 0.02 A of current noise drawn from `seed`: a record with current on
    /// which J, B and Kv are correlated but pinned.
    pub fn paper_motor_noisy_steps(seed: u64) -> Owned {
        let noise = Noise {
            omega: 0.5,
            current: 0.02,
        };
        Owned::paper_motor(Profile::Steps, 0.015, 2000, noise, seed)
    }

    /// `n` samples of `dt`, all zero, no coast-down.
    fn zeros(dt: f32, n: usize) -> Owned {
        Owned {
            dt,
            v: vec![0.0; n],
            tl: vec![0.0; n],
            omega: vec![0.0; n],
            current: vec![0.0; n],
            coast_from: None,
        }
    }

    pub fn new(
        p: &ModelParams,
        exp: Experiment,
        dt: f32,
        n: usize,
        noise: Noise,
        seed: u64,
    ) -> Owned {
        let mut o = Owned::zeros(dt, n);
        let buffers = Buffers {
            v: &mut o.v,
            tl: &mut o.tl,
            omega: &mut o.omega,
            current: &mut o.current,
        };
        synthesize(p, &exp, dt, noise, seed, None, buffers).unwrap();
        o
    }
    pub fn record(&self, with_current: bool, with_load: bool) -> Record<'_> {
        Record {
            dt: self.dt,
            v: &self.v,
            omega: &self.omega,
            current: with_current.then_some(&self.current[..]),
            load: with_load.then_some(&self.tl[..]),
            coast_from: self.coast_from,
            averaged: 1,
        }
    }

    /// A slow record of the commissioning experiment ([`slow_input`]: `n` samples of `dt`
    /// within `voltage`, ending with a coast-down) run on a noise-free [`SimulatedPlant`] of
    /// `p`, one drive sample per record sample.
    pub fn commissioning(p: &ModelParams, n: usize, dt: f32, voltage: f32) -> Owned {
        let quiet = Noise {
            omega: 0.0,
            current: 0.0,
        };
        Owned::commissioning_noisy(p, n, dt, voltage, quiet, 1)
    }

    /// [`Owned::commissioning`] with the plant's sensor `noise` drawn from `seed`.
    pub fn commissioning_noisy(
        p: &ModelParams,
        n: usize,
        dt: f32,
        voltage: f32,
        noise: Noise,
        seed: u64,
    ) -> Owned {
        let mut plant = SimulatedPlant::new(p, dt, noise.omega, noise.current, seed).unwrap();
        let mut o = Owned {
            coast_from: Some(coast_start(n)),
            ..Owned::zeros(dt, n)
        };
        for k in 0..n {
            let input = slow_input(k, n, voltage);
            let s = plant.apply(input);
            (o.v[k], o.omega[k], o.current[k]) = (input.recorded_volts(), s.omega, s.current);
        }
        o
    }
}

/// The default pipeline's fit of records (the default problem), with what the fit's
/// analysis and refits work on: the records' objective and the fit's search space.
pub struct Fitted<'r, 'a> {
    pub fit: crate::fit::identify::Identification,
    pub objective: crate::fit::objective::Objective<'r, 'a>,
    pub space: crate::fit::space::Space,
}

impl<'r, 'a> Fitted<'r, 'a> {
    /// The default pipeline's fit of `rec` with random seed `seed`.
    pub fn of(rec: &'r [Record<'a>], seed: u64) -> Self {
        use crate::fit::pipeline::IdentifyConfig;
        use crate::fit::space::{ProblemSpec, Space};
        let spec = ProblemSpec::default();
        let cfg = IdentifyConfig::default_pipeline(seed);
        let fit = crate::fit::identify::identify(rec, &spec, &cfg, |_| {
            core::ops::ControlFlow::Continue(())
        })
        .unwrap();
        Fitted {
            fit,
            objective: crate::fit::objective::Objective::new(rec).unwrap(),
            space: Space::new(&spec, cfg.log_scale).unwrap(),
        }
    }

    /// The residual variance at the fit (its SSE over the degrees of freedom).
    pub fn sigma2(&self) -> f64 {
        let dof = self.fit.cost.residuals as f64 - self.space.dim() as f64;
        self.fit.cost.sse / dof
    }

    /// The local analysis at the fit, before any profile check, and its profile lines.
    pub fn analysis(
        &self,
    ) -> (
        crate::fit::identifiability::Identifiability,
        crate::fit::identifiability::ProfileLines,
    ) {
        let mut lines = Default::default();
        let u = self.space.unit(&self.fit.params);
        let id = crate::fit::identifiability::analyse(
            &self.objective,
            &self.space,
            &u[..self.space.dim()],
            &self.fit.cost,
            false,
            &mut lines,
        )
        .unwrap();
        (id, lines)
    }
}
