//! `motor-id tune`: current-loop and speed-loop PI gains from identified parameters, and
//! their step responses simulated on the identified model ([`crate::tuning`]).

use crate::limits_args::within;
use crate::output::write_json;
use crate::plot::{draw, Panel, Series};
use crate::report::{ByParam, Num, SCHEMA_VERSION};
use crate::tuning::{gains, step, Design, Gains, Loop, StepResponse};
use crate::validation::read_params_report;
use anyhow::Result;
use clap::Args;
use motor_id_shared::ParamId;
use plotters::style::{BLUE, RED};
use serde::Serialize;
use std::path::PathBuf;

/// Arguments of `tune`.
#[derive(Args, Debug)]
pub struct TuneArgs {
    /// The parameters: a JSON report of `identify`, `board` (a commissioned board's
    /// `params`) or `diagnose`.
    #[arg(long, value_name = "REPORT.json")]
    pub params: PathBuf,
    /// Current-loop bandwidth [Hz] (at most a tenth of the rate).
    #[arg(long, default_value_t = 200.0, value_parser = within(0.01, 1e6))]
    pub current_bandwidth: f32,
    /// Speed-loop phase margin [deg] (symmetric optimum; 37 is Kessler's a = 2; 1 to 85).
    #[arg(long, default_value_t = 60.0, value_parser = within(1.0, 85.0))]
    pub phase_margin: f32,
    /// Control rate: sampling and PWM update [Hz] (1 to 10,000,000).
    #[arg(long, default_value_t = 10_000.0, value_parser = within(1.0, 1e7))]
    pub rate: f32,
    /// Voltage limit of the bridge [V].
    #[arg(long, default_value_t = 50.0, value_parser = within(f32::MIN_POSITIVE, 1e5))]
    pub voltage: f32,
    /// Write the JSON report here.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write a PNG plot of the two step responses here.
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// No progress on stderr. This command's work is short and shows none; the option is
    /// taken as on every command, so that scripts can pass it everywhere.
    #[arg(long, short)]
    pub quiet: bool,
}

/// The `tune` report.
#[derive(Serialize, Debug)]
struct TuneReport {
    schema_version: u32,
    /// The parameters tuned for.
    params: ByParam<Num>,
    /// The design rules, in words.
    rules: &'static str,
    /// Control rate [Hz] and voltage limit [V].
    rate_hz: f64,
    voltage: f64,
    #[serde(flatten)]
    gains: Gains,
    /// The current loop's step response on the model.
    current_step: StepResponse,
    /// The speed loop's step response on the model.
    speed_step: StepResponse,
    /// Gains that rest on a parameter the report's data did not pin, in words (empty when
    /// every parameter they use is pinned, or the report does not say).
    caveats: Vec<String>,
}

/// The parameters each loop's gains are made of: the current loop's `Kp = La wc`,
/// `Ki = Ra wc`; the speed loop's `Kp = J / (a Kv T)`.
const DEPENDS_ON: [(&str, [ParamId; 2]); 2] = [
    ("current loop", [ParamId::La, ParamId::Ra]),
    ("speed loop", [ParamId::J, ParamId::Kv]),
];

/// What the gains of each loop rest on that the data did not pin.
fn caveats(unpinned: &[ParamId]) -> Vec<String> {
    DEPENDS_ON
        .iter()
        .filter_map(|(name, ids)| {
            let loose: Vec<&str> = ids
                .iter()
                .filter(|id| unpinned.contains(id))
                .map(|id| id.name())
                .collect();
            (!loose.is_empty()).then(|| {
                format!(
                    "the {name}'s gains scale with {}, which the report's data did not pin: they are no better than that value",
                    loose.join(" and ")
                )
            })
        })
        .collect()
}

const RULES: &str = "current loop: PI zero on the armature pole (Ti = La/Ra, Kp = La wc); \
                     speed loop: symmetric optimum (Kessler) at the asked phase margin";

/// Run `tune`.
pub fn run(a: &TuneArgs) -> Result<()> {
    let report = read_params_report(&a.params)?;
    let (p, caveats) = (report.params, caveats(&report.unpinned));
    let design = Design {
        current_bandwidth_hz: f64::from(a.current_bandwidth),
        phase_margin_deg: f64::from(a.phase_margin),
        rate_hz: f64::from(a.rate),
        voltage: f64::from(a.voltage),
    };
    let g = gains(&p, &design)?;
    // Ten current-loop time constants; ten speed-loop ones.
    let tau_i = 1.0 / (std::f64::consts::TAU * g.current_loop.bandwidth_hz);
    let tau_w = 1.0 / (std::f64::consts::TAU * g.speed_loop.bandwidth_hz);
    let current_step = step(&p, &g, &design, Loop::Current, 10.0 * tau_i)?;
    let speed_step = step(&p, &g, &design, Loop::Speed, 20.0 * tau_w)?;
    let report = TuneReport {
        schema_version: SCHEMA_VERSION,
        params: ParamId::MOTOR
            .into_iter()
            .map(|id| (id, Num(p.get(id))))
            .collect(),
        rules: RULES,
        rate_hz: design.rate_hz,
        voltage: design.voltage,
        gains: g,
        current_step,
        speed_step,
        caveats,
    };
    for c in &report.caveats {
        eprintln!("warning: {c}");
    }
    println!("{RULES}");
    for (name, pi, unit, s) in [
        (
            "current",
            g.current_loop,
            "V/A, V/(A s)",
            &report.current_step,
        ),
        ("speed", g.speed_loop, "A s/rad, A/rad", &report.speed_step),
    ] {
        println!(
            "{name:<7} loop: kp = {:.6e}, ki = {:.6e} [{unit}], designed {:.2} Hz; on the model: \
             63 % in {:.4} s ({:.2} Hz as a first-order lag), overshoot {:.1} %",
            pi.kp,
            pi.ki,
            pi.bandwidth_hz,
            s.t63_s,
            s.bandwidth_hz,
            100.0 * s.overshoot
        );
    }
    println!(
        "speed loop phase margin {:.0} deg by design",
        g.phase_margin_deg
    );
    if let Some(path) = &a.json {
        write_json(path, &report)?;
    }
    if let Some(path) = &a.plot {
        let panel = |title: String, y_label, s: &StepResponse| {
            (title, y_label, s.trace.clone(), s.reference)
        };
        let traces = [
            panel(
                format!(
                    "current step on the model ({:.3} A)",
                    report.current_step.reference
                ),
                "i [A]",
                &report.current_step,
            ),
            panel(
                format!(
                    "speed step on the model ({:.3} rad/s)",
                    report.speed_step.reference
                ),
                "omega [rad/s]",
                &report.speed_step,
            ),
        ];
        let references: Vec<Vec<f32>> = traces
            .iter()
            .map(|(_, _, (t, _, _), r)| vec![*r as f32; t.len()])
            .collect();
        let panels: Vec<Panel> = traces
            .iter()
            .zip(&references)
            .map(|((title, y_label, (t, y, _), _), reference)| Panel {
                title: title.clone(),
                x_label: "t [s]",
                y_label,
                series: vec![
                    Series {
                        label: "reference",
                        x: t,
                        y: reference,
                        color: RED,
                    },
                    Series {
                        label: "response",
                        x: t,
                        y,
                        color: BLUE,
                    },
                ],
                log_y: false,
                categories: None,
                spans: vec![],
            })
            .collect();
        draw(path, &panels)?;
    }
    Ok(())
}
