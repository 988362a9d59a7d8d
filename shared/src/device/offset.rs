//! What is left of the current sensor's offset after the probe subtracted it, read again in
//! the slow record's coast-down. With the bridge open no armature current flows once the
//! freewheel current has decayed, in `La/Ra ln(1 + Ra i / (Vbus + Kv w))`, under one
//! La/Ra (FIRMWARE.md, "Coast-down"), so every current reading there is the offset and
//! noise. The probe reads the offset over 0.25 s; what is left of it is a constant error on
//! every current reading that the fit does not model. Against the noise of a mean over many
//! drive readings it narrowed the deviations: at 2 kHz and 20 mA of noise, 96.5 % of the
//! commissioning benchmark's pinned estimates lay within 3 σ, 98.5 % with the offset read
//! over 5 s instead, 98.7 % with it read again here (docs/measurements/commissioning.md).
//! The coast-down holds many more readings than the probe's window, at no cost in time.

use crate::device::rest::Rest;
use crate::model::record::Record;

/// La/Ra left out at the start of the coast-down: the freewheel current is gone within one.
const DECAY_TAUS: f32 = 3.0;

/// The offset left in the records' currents: the mean current of the first record's
/// coast-down after [`DECAY_TAUS`] times `tau_e`, pooled with the probe's own readings (each
/// reading weighs one; a record sample of averaged readings as many as it averages); 0 when
/// the first record has no current or no coast-down beyond the decay.
pub fn coast_offset(records: &[Record], rest: &Rest, tau_e: f32) -> f32 {
    let Some(slow) = records.first() else {
        return 0.0;
    };
    let (Some(current), Some(from)) = (slow.current, slow.coast_from) else {
        return 0.0;
    };
    // Sample `from` is the mean over the step before the bridge opens (or the reading at
    // its instant): the open steps follow it.
    let decay = libm::ceilf(DECAY_TAUS * tau_e / slow.dt);
    let skip = match decay.is_finite() && decay >= 0.0 {
        true => 1 + decay.min(current.len() as f32) as usize,
        false => current.len(),
    };
    let open = current.get(from.saturating_add(skip)..).unwrap_or(&[]);
    if open.is_empty() {
        return 0.0;
    }
    let mean = open.iter().map(|&c| c as f64).sum::<f64>() / open.len() as f64;
    let coast = (open.len() as u64 * u64::from(slow.averaged.max(1))) as f64;
    let probe = f64::from(rest.offset_readings);
    (mean * coast / (coast + probe)) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rest(readings: u32) -> Rest {
        Rest {
            current_offset: 0.0,
            sigma_omega: 0.1,
            sigma_current: 0.02,
            offset_readings: readings,
        }
    }

    #[test]
    fn the_coast_down_s_mean_current_past_the_decay_is_pooled_with_the_probe_s() {
        // 100 samples, the bridge open from 60; La/Ra of 2 steps: from 60 + 1 + 6 on, the
        // readings are the left offset (3 mA) and a tail of decaying current before.
        let v = [0.0f32; 100];
        let mut current = [5.0f32; 100];
        for (k, c) in current.iter_mut().enumerate().skip(60) {
            *c = if k < 67 { 0.5 } else { 0.003 };
        }
        let record = |averaged| Record {
            dt: 1e-3,
            v: &v,
            omega: &v,
            current: Some(&current),
            load: None,
            coast_from: Some(60),
            averaged,
        };
        // 33 readings against the probe's 33: half of the left offset.
        let half = coast_offset(&[record(1)], &rest(33), 2e-3);
        assert!((half - 0.0015).abs() < 1e-7, "{half}");
        // Each sample the mean of 10 readings: 330 against 33.
        let most = coast_offset(&[record(10)], &rest(33), 2e-3);
        assert!((most - 0.003 * 330.0 / 363.0).abs() < 1e-7, "{most}");
        // No coast-down, no current, or a decay past the record's end: nothing.
        let none = Record {
            coast_from: None,
            ..record(1)
        };
        assert_eq!(coast_offset(&[none], &rest(33), 2e-3), 0.0);
        let speed_only = Record {
            current: None,
            ..record(1)
        };
        assert_eq!(coast_offset(&[speed_only], &rest(33), 2e-3), 0.0);
        assert_eq!(coast_offset(&[record(1)], &rest(33), 1.0), 0.0);
        assert_eq!(coast_offset(&[record(1)], &rest(33), f32::NAN), 0.0);
    }
}
