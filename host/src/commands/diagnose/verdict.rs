//! The significance rule: is an effect real, or the least-bad way to fit noise?
//!
//! An effect is accepted only when all of these hold:
//! - on the training records, the Bayesian information criterion falls by more than 10
//!   (`n ln(SSE_e / SSE_0) + k ln n`, with `n` residuals and `k` added parameters): strong
//!   evidence, where fitting noise with `k` extra parameters lowers `n ln SSE` by about `k`
//!   but pays `k ln n`;
//! - on the held-out records, which the fit never saw, the RMSE falls by at least 2 % and by
//!   at least 10 % of the misfit above the measured noise (`rmse^2 - sigma^2`). Data without
//!   an unmodelled effect is fitted to the noise by the baseline already, so no effect can
//!   pass this, and the verdict is `null`;
//! - the misfit it removes from the held-out records (in quadrature, `before^2 - after^2`)
//!   is at least 0.002 % of the held-out speed's RMS (noise-free records have no noise to
//!   measure against; smaller changes are numerics, not physics: the simulation's f32 state,
//!   its sums compensated, holds about 1e-7 of it, two hundred times under this floor);
//! - the effect is not below the resolution of the sampling: a tacho delay under half a
//!   sample is indistinguishable from a different convention of when readings are taken.
//!
//! The held-out half has a second path, for an effect that completes the model where it
//! acts (the BIC drop, the numerics floor and the resolution above hold on it too): on
//! every channel it changes (the speed, the current, or both), that channel's held-out RMSE
//! falls by 0.5 % or more, by half or more of its misfit above its noise, and to within 1 %
//! of the noise (the noise estimate's own accuracy), and a channel it does not change rises
//! by no more than 0.5 %; the joint misfit may then fall by less than 2 %. A tacho's delay
//! of half a sample to one at 5-10 kHz, the acceleration times 0.05-0.2 ms, is a fraction
//! of the noise on all but a few hundred samples of each edge: it takes the speed's
//! held-out misfit from about 1.008 to 1.002 times the noise, a 0.6 % fall that the 2 %
//! missed. A proxy shaves a little of a channel's misfit and leaves the rest: judged on the
//! joint misfit instead of each channel's, a current offset was named for an untold
//! cogging whose speed sat under its noise estimate (docs/measurements/blind-checks.md).

use crate::fit::Fit;

/// Smallest BIC drop on the training records.
const BIC_DROP: f64 = 10.0;
/// Smallest relative drop of the held-out RMSE.
const HOLDOUT_DROP: f32 = 0.02;
/// Smallest share of the held-out misfit above noise that must go.
const EXCESS_SHARE: f32 = 0.1;
/// Smallest relative drop of the held-out RMSE, on every channel the effect acts on, for an
/// effect that completes the model there ([`COMPLETED_SHARE`]).
const CHANNEL_DROP: f32 = 0.005;
/// Smallest share of a channel's held-out misfit above its noise that an effect completing
/// the model there removes.
const COMPLETED_SHARE: f32 = 0.5;
/// Largest held-out RMSE, over the channel's measured noise, that an effect completing the
/// model there leaves: the noise estimate's own accuracy (a quiet tacho's read 0.7 % low,
/// docs/measurements/blind-checks.md).
const COMPLETED_AT_NOISE: f32 = 1.01;

/// Smallest held-out misfit removed (in quadrature) relative to the held-out speed's RMS.
/// (A drop of the RMSE of 2e-4 of it hid a tacho's delay of 0.76 sample that a fit pinned
/// to 1.4 % and that took the held-out misfit from 1.18 to 1.00 times the noise: on a
/// quiet tacho, 0.05 rad/s on 134 rad/s RMS, that floor was half the noise;
/// docs/measurements/blind-checks.md.)
const REMOVED_SHARE_OF_SIGNAL: f32 = 2e-5;

/// A model's held-out misfit: both channels' joint one (in speed units, see
/// [`super::data::Scored::holdout_joint`]) and each channel's own.
#[derive(Clone, Copy, Debug)]
pub struct HeldOut {
    /// The joint misfit [rad/s].
    pub joint: f32,
    /// The speed's RMSE [rad/s].
    pub speed: f32,
    /// The current's RMSE [A], when current is fitted.
    pub current: Option<f32>,
}

/// What the rule needs of a fitted model.
pub struct Candidate {
    sse: f64,
    residuals: usize,
    held_out: HeldOut,
    added_params: usize,
    resolvable: bool,
    /// The channels the added effect changes: speed, current.
    acts_on: (bool, bool),
}

impl Candidate {
    /// A fit, its held-out misfit, how many parameters it adds to the reference and the
    /// channels they change (speed, current).
    pub fn of(
        fit: &Fit,
        held_out: HeldOut,
        added_params: usize,
        acts_on: (bool, bool),
    ) -> Candidate {
        Candidate {
            sse: fit.result.cost.sse,
            residuals: fit.result.cost.residuals,
            held_out,
            added_params,
            resolvable: true,
            acts_on,
        }
    }

    /// Mark an effect whose size is below what the sampling resolves.
    pub fn unresolvable(mut self, unresolvable: bool) -> Candidate {
        self.resolvable &= !unresolvable;
        self
    }
}

/// The held-out data's scales.
#[derive(Clone, Copy, Debug)]
pub struct Holdout {
    /// Measured speed noise [rad/s].
    pub noise: f32,
    /// RMS of the measured speed [rad/s].
    pub signal_rms: f32,
    /// Measured current noise [A], when the records hold a current (judged only where
    /// current is fitted).
    pub current_noise: Option<f32>,
}

/// True when `candidate` is a real improvement over `reference` (module doc).
pub fn significant(reference: &Candidate, candidate: &Candidate, holdout: &Holdout) -> bool {
    let n = reference.residuals.max(1) as f64;
    let bic = n
        * (candidate.sse.max(f64::MIN_POSITIVE) / reference.sse.max(f64::MIN_POSITIVE)).ln()
        + candidate.added_params as f64 * n.ln();
    candidate.resolvable
        && bic < -BIC_DROP
        && (predicts_better(reference.held_out.joint, candidate.held_out.joint, holdout)
            || completes(reference, candidate, holdout))
}

/// Whether `candidate` completes the model where its effect acts (module doc): on every
/// channel it changes, the held-out RMSE falls by [`CHANNEL_DROP`], by [`COMPLETED_SHARE`]
/// of that channel's misfit above its noise and to within [`COMPLETED_AT_NOISE`] of the
/// noise; on a channel it does not change (a refit of everything moves it too), the RMSE
/// rises by no more than [`CHANNEL_DROP`]; and the joint misfit it removes is more than
/// numerics. (A channel already at its noise cannot be completed: an effect acting on it
/// is judged by the 2 % alone.)
fn completes(reference: &Candidate, candidate: &Candidate, holdout: &Holdout) -> bool {
    let channel = |acts: bool, before: f32, after: f32, noise: f32| match acts {
        true => {
            before * before > noise * noise
                && after <= COMPLETED_AT_NOISE * noise
                && removes(before, after, noise, CHANNEL_DROP, COMPLETED_SHARE)
        }
        false => after <= (1.0 + CHANNEL_DROP) * before,
    };
    let (before, after) = (&reference.held_out, &candidate.held_out);
    let (on_speed, on_current) = candidate.acts_on;
    let speed = channel(on_speed, before.speed, after.speed, holdout.noise);
    let current = match (before.current, after.current, holdout.current_noise) {
        (Some(b), Some(a), Some(noise)) => channel(on_current, b, a, noise),
        // No current fitted: only an effect the speed shows can be judged.
        _ => on_speed,
    };
    (on_speed || on_current)
        && speed
        && current
        && above_numerics(before.joint, after.joint, holdout)
}

/// The held-out half of the rule: a model whose held-out RMSE is `after` predicts the
/// held-out records better than one at `before` by at least 2 %, by 10 % of the misfit
/// above the noise and by more than numerics. What tells two models of different forms
/// apart ([`super::found::LookAlike`]): on the training records each fits its own way, and
/// the prediction judges them, and the same floors hold there.
pub fn predicts_better(before: f32, after: f32, holdout: &Holdout) -> bool {
    removes(before, after, holdout.noise, HOLDOUT_DROP, EXCESS_SHARE)
        && above_numerics(before, after, holdout)
}

/// Whether a held-out RMSE going from `before` to `after` falls by the share `drop` of
/// itself and, in quadrature, by the share `share` of the misfit above `noise` (none when
/// it is at or under the noise).
fn removes(before: f32, after: f32, noise: f32, drop: f32, share: f32) -> bool {
    let excess = (before * before - noise * noise).max(0.0);
    after <= (1.0 - drop) * before && before * before - after * after >= share * excess
}

/// Whether the misfit removed from `before` to `after` (in quadrature) is more than
/// numerics: [`REMOVED_SHARE_OF_SIGNAL`] of the held-out speed's RMS.
fn above_numerics(before: f32, after: f32, holdout: &Holdout) -> bool {
    before * before - after * after >= (REMOVED_SHARE_OF_SIGNAL * holdout.signal_rms).powi(2)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cand(sse: f64, holdout: f32, k: usize) -> Candidate {
        Candidate {
            sse,
            residuals: 2000,
            held_out: HeldOut {
                joint: holdout,
                speed: holdout,
                current: None,
            },
            added_params: k,
            resolvable: true,
            acts_on: (true, false),
        }
    }

    fn h(noise: f32) -> Holdout {
        Holdout {
            noise,
            signal_rms: 100.0,
            current_noise: None,
        }
    }

    #[test]
    fn noise_fitting_is_refused_and_a_real_effect_accepted() {
        let base = cand(2000.0 * 0.25, 0.5, 0);
        // One parameter that lowers SSE by 2 sigma^2 (noise fitting): BIC rises.
        assert!(!significant(
            &base,
            &cand(2000.0 * 0.25 - 0.5, 0.499, 1),
            &h(0.5)
        ));
        // Train much better but held-out not: refused.
        assert!(!significant(&base, &cand(400.0, 0.499, 1), &h(0.45)));
        // Both much better: accepted, unless below the sampling's resolution.
        assert!(significant(&base, &cand(400.0, 0.46, 1), &h(0.45)));
        assert!(!significant(
            &base,
            &cand(400.0, 0.46, 1).unresolvable(true),
            &h(0.45)
        ));
        // A quiet tacho (0.05 rad/s on a speed of 134 rad/s RMS) delayed by 0.76 sample:
        // the delay takes the held-out misfit from 1.18 times the noise to the noise, a fall
        // of 0.009 rad/s (under the old floor, 2e-4 of the signal: 0.027), and is an effect
        // (blind checks, 2 kHz).
        let quiet = Holdout {
            noise: 0.0504,
            signal_rms: 134.0,
            current_noise: None,
        };
        let delayed = cand(2000.0 * 0.0571f64.powi(2), 0.05926, 0);
        assert!(significant(
            &delayed,
            &cand(2000.0 * 0.0500f64.powi(2), 0.0503, 1),
            &quiet
        ));
        // On noise-free data a 10 % drop of a tiny misfit is numerics, not an effect.
        let clean = cand(2000.0 * 1e-6, 0.001, 0);
        let tiny = cand(2000.0 * 0.5e-6, 0.0009, 1);
        assert!(!significant(
            &clean,
            &tiny,
            &Holdout {
                noise: 1e-5,
                signal_rms: 100.0,
                current_noise: None,
            }
        ));
    }

    /// A candidate whose held-out misfit is `speed` [rad/s] and `current` [A] (none: no
    /// current fitted; the joint one over noises of 0.05 rad/s and 0.02 A), its effect
    /// acting on `acts_on`.
    fn two_channels(
        sse: f64,
        speed: f32,
        current: Option<f32>,
        acts_on: (bool, bool),
    ) -> Candidate {
        let current_share = current.map_or(0.0, |i| (i / 0.02).powi(2));
        let channels = if current.is_some() { 2.0 } else { 1.0 };
        let joint = 0.05 * (((speed / 0.05).powi(2) + current_share) / channels).sqrt();
        Candidate {
            sse,
            residuals: 2000,
            held_out: HeldOut {
                joint,
                speed,
                current,
            },
            added_params: 1,
            resolvable: true,
            acts_on,
        }
    }

    #[test]
    fn a_small_fall_names_only_what_completes_the_channels_it_acts_on() {
        let noises = Holdout {
            noise: 0.05,
            signal_rms: 134.0,
            current_noise: Some(0.02),
        };
        let none = (false, false);
        let (on_speed, on_current) = ((true, false), (false, true));
        let base = two_channels(2000.0 * 0.0026, 0.0504, Some(0.0200), none);
        // A tacho delay (the speed reading only): the speed from 1.008 to 1.002 times its
        // noise, the current as it was. The joint misfit falls by 0.3 %, under the 2 %.
        let delay = two_channels(2000.0 * 0.0025, 0.0501, Some(0.0200), on_speed);
        assert!(delay.held_out.joint > (1.0 - HOLDOUT_DROP) * base.held_out.joint);
        assert!(significant(&base, &delay, &noises));
        // A delay that takes the speed from 1.02 to 1.005 times its noise while the refit
        // leaves the current 0.8 % worse: the joint misfit still falls (by 0.35 %), but a
        // channel the effect does not act on got worse: refused.
        let quiet = Holdout {
            signal_rms: 10.0,
            ..noises
        };
        let before = two_channels(2000.0 * 0.0026, 0.0510, Some(0.0200), none);
        let worse = two_channels(2000.0 * 0.0025, 0.05025, Some(0.02016), on_speed);
        assert!(worse.held_out.joint < before.held_out.joint);
        assert!(!significant(&before, &worse, &quiet));
        let kept = two_channels(2000.0 * 0.0025, 0.05025, Some(0.0200), on_speed);
        assert!(significant(&before, &kept, &quiet));
        // Without a current fitted, the speed alone judges a speed effect; an effect on the
        // current alone cannot be judged.
        let speed_base = two_channels(2000.0 * 0.0026, 0.0504, None, none);
        let speed_only = Holdout {
            current_noise: None,
            ..noises
        };
        let delay_alone = two_channels(2000.0 * 0.0025, 0.0501, None, on_speed);
        assert!(significant(&speed_base, &delay_alone, &speed_only));
        let blind = two_channels(2000.0 * 0.0025, 0.0501, None, on_current);
        assert!(!significant(&speed_base, &blind, &speed_only));
        // A fall of 0.64 % that leaves the speed within 1 % of its noise but removes only
        // 41 % of its excess: not complete.
        let most = two_channels(2000.0 * 0.0027, 0.0508, Some(0.0200), none);
        let partial = two_channels(2000.0 * 0.0026, 0.050475, Some(0.0200), on_speed);
        assert!(!significant(&most, &partial, &noises));
        // Half the excess removed by a 1.2 % fall, but 1.2 % above the noise left: not at
        // the noise, not complete.
        let above = two_channels(2000.0 * 0.0027, 0.0512, Some(0.0200), none);
        let short = two_channels(2000.0 * 0.0026, 0.0506, Some(0.0200), on_speed);
        assert!(!significant(&above, &short, &noises));
        // A current offset (the current reading only) that completes the current: from
        // 1.03 to 1.002 times its noise, the speed as it was.
        let offset_base = two_channels(2000.0 * 0.0026, 0.0500, Some(0.0206), none);
        let offset = two_channels(2000.0 * 0.0025, 0.0500, Some(0.02004), on_current);
        assert!(significant(&offset_base, &offset, &noises));
        // A proxy on the current beside an untold effect that leaves the speed under its
        // noise estimate (0.9 of it) and the current at 1.1: shaving the current to 1.09
        // takes the joint misfit from 1.005 times the noise to under it (all its excess, a
        // 0.54 % fall), but removes a tenth of the current's own excess: refused.
        let shaved_base = two_channels(2000.0 * 0.003, 0.045, Some(0.0220), none);
        let proxy = two_channels(2000.0 * 0.0029, 0.045, Some(0.0218), on_current);
        assert!(
            proxy.held_out.joint < 0.05
                && proxy.held_out.joint < 0.995 * shaved_base.held_out.joint
        );
        assert!(!significant(&shaved_base, &proxy, &noises));
        // An effect on both channels completes neither when one of them keeps its excess.
        let both_base = two_channels(2000.0 * 0.0026, 0.0504, Some(0.0262), none);
        let one_of_two = two_channels(2000.0 * 0.0025, 0.0501, Some(0.0260), (true, true));
        assert!(!significant(&both_base, &one_of_two, &noises));
    }
}
