//! Tests of the profile check (`fit::profile_check`).

use super::walk::{came_back, starts};
use super::*;
use crate::testkit::{Fitted, Owned};

#[test]
fn a_profile_starts_at_the_local_minimum_of_the_others() {
    // The paper motor with current: J, B and Kv correlated. Held 3 deviations off, a
    // parameter's profile refit from its profile line gains under one residual variance
    // (the line is where the local quadratic puts the others); from the optimum with
    // the others unmoved, the refit of a correlated one gains many.
    let data = Owned::paper_motor_noisy_steps(11);
    let rec = [data.record(true, false)];
    let fitted = Fitted::of(&rec, 1);
    let (fit, objective, space) = (&fitted.fit, &fitted.objective, &fitted.space);
    let sigma2 = fitted.sigma2();
    let (_, lines) = fitted.analysis();
    let lm = stopping_at(&LmConfig::default(), 0.01, sigma2);
    let gain = |profile: &Space, start: &[f32; MAX_FREE]| {
        let from = objective
            .cost(&profile.params(&start[..profile.dim()]))
            .unwrap();
        let r = levenberg_marquardt(objective, profile, start, &lm, &mut |_| {
            ControlFlow::Continue(())
        })
        .unwrap();
        (from.sse - r.cost.sse) / sigma2
    };
    let mut unmoved_gains = std::vec::Vec::new();
    for (k, c) in fit.identifiability.params.iter().enumerate() {
        let value = c.value + 3.0 * c.std.expect("pinned");
        let line = lines[k];
        let (profile, start) = profile_start(space, &fit.params, c.id, value, &line).unwrap();
        let on_line = gain(&profile, &start);
        assert!(on_line < 1.0, "{:?}: {on_line} from its line", c.id);
        let unmoved = space.fixing(&fit.params, c.id, value).unwrap();
        unmoved_gains.push(gain(&unmoved, &unmoved.unit(&fit.params)));
    }
    let most = unmoved_gains.iter().copied().fold(0.0, f64::max);
    assert!(most > 10.0, "{unmoved_gains:?}");
}

#[test]
fn the_walk_starts_nearer_only_along_an_informed_direction_whose_deviations_allow() {
    let collected = |std: f32, edge: f32| starts(std, edge).collect::<std::vec::Vec<_>>();
    // A loose direction of deviation 1/16 whose edge lies 2 away (32 deviations): first
    // 10 of them out, 0.3125 of the way; with the edge 8 away, 0.078125 of it (sums of
    // powers of two, exact in f32).
    assert_eq!(collected(0.0625, 2.0), [0.3125, 0.5, 1.0]);
    assert_eq!(collected(0.0625, 8.0), [0.078125, 0.5, 1.0]);
    // Half way to the edge is nearer than 10 deviations: half way first, as along a flat one.
    assert_eq!(collected(0.0625, 1.0), [0.5, 1.0]);
    assert_eq!(collected(f32::INFINITY, 1.0), [0.5, 1.0]);
}

#[test]
fn a_descent_came_back_only_when_it_landed_near_the_optimum() {
    let (u0, start) = ([0.5f32, 0.5], [0.9f32, 0.5]);
    // Back home, or a fifth of the way out: came back.
    assert!(came_back(&u0, &start, &[0.5, 0.5]));
    assert!(came_back(&u0, &start, &[0.58, 0.5]));
    // Stayed out, or as far out across (a valley that bends): not came back.
    assert!(!came_back(&u0, &start, &[0.85, 0.5]));
    assert!(!came_back(&u0, &start, &[0.5, 0.2]));
}

#[test]
fn a_descent_ends_where_it_came_back_and_the_check_goes_on() {
    // The paper motor with current, a descent from half way to the box's edge along J:
    // ended at the first point that came back, it spends fewer simulations than the
    // full descent, stops there (came back, above the optimum's cost), and the check's
    // next run still starts.
    let data = Owned::paper_motor_noisy_steps(11);
    let rec = [data.record(true, false)];
    let fitted = Fitted::of(&rec, 1);
    let (fit, objective, space) = (&fitted.fit, &fitted.objective, &fitted.space);
    let dim = space.dim();
    let u0 = space.unit(&fit.params);
    let k = space
        .free()
        .iter()
        .position(|f| f.id == ParamId::J)
        .unwrap();
    let mut start = u0;
    start[k] = 0.5 * (u0[k] + 1.0);
    let lm = LmConfig::default();
    let mut progress = |_| ControlFlow::Continue(());
    let mut runs = Runs {
        spent: 0,
        progress: &mut progress,
        stopped: false,
    };
    let back = |u: &[f32]| came_back(&u0[..dim], &start[..dim], u);
    let full = runs.refine(objective, space, &start[..dim], &lm, &|_| false);
    let full = full.unwrap();
    assert!(back(&full.u[..dim]), "{:?}", &full.u[..dim]);
    let ended = runs.refine(objective, space, &start[..dim], &lm, &back);
    let ended = ended.unwrap();
    assert!(back(&ended.u[..dim]));
    assert!(ended.evaluations < full.evaluations, "{ended:?} {full:?}");
    assert!(ended.cost.sse > full.cost.sse);
    assert_eq!(runs.spent, full.evaluations + ended.evaluations);
    assert!(runs
        .refine(objective, space, &start[..dim], &lm, &back)
        .is_some());
}

#[test]
fn a_refit_ends_once_the_level_it_needs_is_out_of_reach_and_not_before() {
    // The paper motor with current, Ra held 20 deviations off the optimum (its profile's
    // rise some 400 residual variances). Asked whether the refit comes under 9 residual
    // variances above the optimum, it stops at its start's normal equations; asked for
    // a level it can reach (the full space from the same start), it goes on to it.
    let data = Owned::paper_motor_noisy_steps(11);
    let rec = [data.record(true, false)];
    let fitted = Fitted::of(&rec, 1);
    let (fit, objective, space) = (&fitted.fit, &fitted.objective, &fitted.space);
    let sigma2 = fitted.sigma2();
    let ra = fit.identifiability.params[0];
    assert_eq!(ra.id, ParamId::Ra);
    let held = ra.value + 20.0 * ra.std.expect("pinned");
    let profile = space.fixing(&fit.params, ParamId::Ra, held).unwrap();
    let start = profile.unit(&fit.params);
    let refit = |space: &Space, start: &[f32], needed_below: f64| {
        let lm = LmConfig {
            needed_below,
            ..stopping_at(&LmConfig::default(), PROFILE_TOL, sigma2)
        };
        levenberg_marquardt(objective, space, start, &lm, &mut |_| {
            ControlFlow::Continue(())
        })
        .unwrap()
    };
    let level = fit.cost.sse + 9.0 * sigma2;
    let full = refit(&profile, &start[..profile.dim()], f64::INFINITY);
    assert!(full.iterations > 0, "{full:?}");
    assert!(full.cost.sse > level + 100.0 * sigma2, "{full:?}");
    let ended = refit(&profile, &start[..profile.dim()], level);
    assert_eq!(ended.iterations, 0, "{ended:?}");
    assert!(ended.evaluations < full.evaluations, "{ended:?} {full:?}");
    // The whole space from the same start: the optimum's level is within reach.
    let mut from = space.unit(&fit.params);
    from[0] = space.unit(&fit.params.with(ParamId::Ra, held))[0];
    let reached = refit(space, &from[..space.dim()], level);
    assert!(reached.cost.sse < level, "{reached:?}");
}

#[test]
fn a_profile_that_stays_within_a_loose_deviation_would_not_widen_its_parameter() {
    // One start-up step of the paper motor with current under heavy noise: a direction
    // informed more loosely than pinned allows (finite, not flat). A pinned parameter
    // whose profile line moves along it by less than one of its deviations is not
    // profiled; profiled anyway, its rise at 3 deviations is close to 9 (it would widen its
    // deviation by a few per cent at most), and the parameters so left are not all of them.
    let noise = crate::model::synth::Noise {
        omega: 20.0,
        current: 2.0,
    };
    let data = Owned::paper_motor(crate::model::profile::Profile::Start, 0.01, 2000, noise, 3);
    let rec = [data.record(true, false)];
    let fitted = Fitted::of(&rec, 2);
    let (fit, objective, space) = (&fitted.fit, &fitted.objective, &fitted.space);
    let (id, lines) = fitted.analysis();
    assert!(!id.unpinned.is_empty(), "{id:?}");
    assert!(id.unpinned.iter().all(|d| d.std.is_finite()), "{id:?}");
    let sigma2 = fitted.sigma2();
    let lm = stopping_at(&LmConfig::default(), PROFILE_TOL, sigma2);
    let mut progress = |_| ControlFlow::Continue(());
    let mut runs = Runs {
        spent: 0,
        progress: &mut progress,
        stopped: false,
    };
    let (mut left, mut profiled_ones) = (0, 0);
    for (k, c) in id.params.iter().enumerate() {
        let Some(std) = c.std.filter(|_| c.pinned) else {
            continue;
        };
        if profiled(&id, space, &lines, c) {
            profiled_ones += 1;
            continue;
        }
        left += 1;
        for side in [-1.0f32, 1.0] {
            let value = f64::from(c.value + side * STEPS as f32 * std);
            let rise = profile_rise(
                objective,
                space,
                &fit.params,
                c.id,
                value,
                &lines[k],
                &fit.cost,
                sigma2,
                &lm,
                &mut runs,
            )
            .expect("a profile");
            assert!(rise > 8.0, "{:?} at {side}: rise {rise}", c.id);
        }
    }
    assert!(
        left > 0 && profiled_ones > 0,
        "left {left}, profiled {profiled_ones}"
    );
}

#[test]
fn a_profile_reaches_along_a_flat_direction_always_and_a_loose_one_by_its_deviations() {
    let mut components = [0.0f32; MAX_FREE];
    (components[0], components[1]) = (0.6, 0.8);
    let loose = Direction {
        components,
        std: 0.5,
    };
    // Moved by 3 x 0.2, the profile's start moves by 0.6 x (1, 0.5): along the direction
    // by 0.6 x (0.6 + 0.4) = 0.6, more than its deviation 0.5; across it (a line of
    // (1, -0.75)) by nothing.
    let mut line = [0.0f32; MAX_FREE];
    (line[0], line[1]) = (1.0, 0.5);
    assert!(reaches_along(&loose, &line, 0.2));
    assert!(!reaches_along(&loose, &line, 0.15));
    (line[0], line[1]) = (1.0, -0.75);
    assert!(!reaches_along(&loose, &line, 0.2));
    let flat = Direction {
        std: f32::INFINITY,
        ..loose
    };
    assert!(reaches_along(&flat, &line, 0.2));
}
