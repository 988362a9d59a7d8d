//! Test support: proptest strategies for every wire message, shared by the fuzz targets of
//! the frame decoder (`wire/frame_fuzz.rs`) and of the board service
//! (`device/service_fuzz.rs`). Numbers lean towards the edges that matter: non-finite and
//! extreme floats, offsets and sample counts around a board's capacity, `u32::MAX`.

use crate::capacity::MAX_ESTIMATES;
use crate::wire::limits::Limits;
use crate::wire::protocol::*;
use proptest::collection::vec;
use proptest::prelude::*;
use proptest::sample::select;
use std::vec::Vec;

/// Any `f32` (NaN and infinities included), with the edge values often.
pub(crate) fn float() -> impl Strategy<Value = f32> + Clone {
    prop_oneof![
        3 => any::<f32>(),
        1 => select(vec![
            0.0,
            -0.0,
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::MIN_POSITIVE,
            f32::MAX,
            -f32::MAX,
            1e-3,
            1.0,
            24.0,
            1e30,
        ]),
    ]
}

fn heapless_vec<const M: usize>(values: Vec<f32>) -> heapless::Vec<f32, M> {
    heapless::Vec::from_slice(&values).expect("generated within capacity")
}

/// Any `u32`, or one near `capacity` (0 ..= capacity + CHUNK, or a multiple of
/// [`CHUNK`] within it) more often.
fn count_near(capacity: u32) -> impl Strategy<Value = u32> + Clone {
    let chunk = CHUNK as u32;
    prop_oneof![
        2 => (0..=capacity / chunk + 1).prop_map(move |k| k * chunk),
        2 => 0..=capacity + chunk,
        1 => any::<u32>(),
        1 => Just(u32::MAX),
    ]
}

/// A record chunk at `offset`: `n` samples of voltage, speed of `n` samples mostly (any
/// length sometimes), current of `n`, none, or any length.
fn record_chunk(capacity: u32) -> impl Strategy<Value = HostMessage> {
    (count_near(capacity), 0..=CHUNK).prop_flat_map(|(offset, n)| {
        let other = 0..=CHUNK;
        (
            vec(float(), n),
            prop_oneof![4 => vec(float(), n), 1 => vec(float(), other.clone())],
            prop_oneof![2 => vec(float(), n), 2 => Just(Vec::new()), 1 => vec(float(), other)],
        )
            .prop_map(move |(v, omega, current)| HostMessage::RecordChunk {
                offset,
                v: heapless_vec(v),
                omega: heapless_vec(omega),
                current: heapless_vec(current),
            })
    })
}

/// Any limits (mostly unusable ones: any floats), or usable ones near the defaults (a
/// budget of at most the default 60 s, which bounds a fuzzed commissioning's length).
pub(crate) fn limits() -> impl Strategy<Value = Limits> {
    prop_oneof![
        1 => [float(), float(), float(), float()].prop_map(|[voltage, current, speed, budget]| {
            Limits {
                voltage,
                current,
                speed,
                budget,
            }
        }),
        1 => (1.0f32..100.0, 0.5f32..50.0, 10.0f32..1000.0, 5.0f32..60.0).prop_map(
            |(voltage, current, speed, budget)| Limits {
                voltage,
                current,
                speed,
                budget,
            }
        ),
    ]
}

/// Any pipeline name.
pub(crate) fn pipeline() -> impl Strategy<Value = PipelineName> {
    select(vec![
        PipelineName::Default,
        PipelineName::Board,
        PipelineName::Paper,
    ])
}

/// Any host request, its counts and offsets near a board that holds `capacity` samples:
/// hellos of this and other versions, announcements within and beyond the capacity, chunks
/// in and out of order and of mismatched lengths, jobs, aborts.
pub(crate) fn host_message(capacity: u32) -> impl Strategy<Value = HostMessage> {
    let version = prop_oneof![3 => Just(PROTOCOL_VERSION), 1 => any::<u16>()];
    prop_oneof![
        2 => version.prop_map(|version| HostMessage::Hello { version }),
        2 => (
            float(),
            count_near(capacity),
            any::<bool>(),
            prop_oneof![3 => Just(None), 1 => count_near(capacity).prop_map(Some)]
        )
            .prop_map(|(dt, samples, with_current, coast_from)| {
                HostMessage::IdentifyBegin {
                    dt,
                    samples,
                    with_current,
                    coast_from,
                }
            }),
        6 => record_chunk(capacity),
        1 => (any::<u64>(), pipeline()).prop_map(|(seed, pipeline)| HostMessage::Identify {
            seed,
            pipeline
        }),
        1 => any::<u64>().prop_map(|seed| HostMessage::Commission { seed }),
        1 => Just(HostMessage::ReadParams),
        1 => Just(HostMessage::ClearParams),
        2 => Just(HostMessage::Abort),
        1 => limits().prop_map(HostMessage::Configure),
        1 => Just(HostMessage::ReadLimits),
        1 => (any::<u8>(), count_near(capacity))
            .prop_map(|(record, offset)| HostMessage::ReadRecord { record, offset }),
    ]
}

fn refusal() -> impl Strategy<Value = Refusal> {
    prop_oneof![
        any::<u16>().prop_map(|board| Refusal::VersionMismatch { board }),
        any::<u32>().prop_map(|max| Refusal::RecordTooLong { max }),
        select(vec![
            Refusal::NoSession,
            Refusal::BadChunk,
            Refusal::InvalidRecord,
            Refusal::Trip,
            Refusal::NotAtRest,
            Refusal::SensorFault,
            Refusal::Busy,
            Refusal::PipelineTooLarge,
            Refusal::NoMotion,
            Refusal::TooFast,
            Refusal::BadLimits,
            Refusal::NoRecord,
            Refusal::NoBackEmf,
        ]),
    ]
}

/// Any motor report: up to [`MAX_ESTIMATES`] estimates of any code and value.
pub(crate) fn motor_report() -> impl Strategy<Value = MotorReport> {
    let estimate = (any::<u8>(), float(), float()).prop_map(|(param, value, std)| Estimate {
        param,
        value,
        std,
    });
    (
        vec(estimate, 0..=MAX_ESTIMATES),
        float(),
        any::<u32>(),
        any::<u8>(),
    )
        .prop_map(|(estimates, rmse_omega, evaluations, rank)| MotorReport {
            estimates: heapless::Vec::from_slice(&estimates).expect("within capacity"),
            rmse_omega,
            evaluations,
            rank,
        })
}

/// Any commissioning plan (any numbers, as a corrupt or hostile board may send).
fn plan() -> impl Strategy<Value = Plan> {
    (
        [
            float(),
            float(),
            float(),
            float(),
            float(),
            float(),
            float(),
            float(),
        ],
        (
            float(),
            any::<u16>(),
            float(),
            any::<u16>(),
            float(),
            float(),
        ),
    )
        .prop_map(|(a, b)| Plan {
            current_offset: a[0],
            breakaway_volts: a[1],
            ra: a[2],
            tau_e: a[3],
            kv: a[4],
            tau_m: a[5],
            back_emf_current: a[6],
            volts: a[7],
            fast_dt: b.0,
            fast_samples: b.1,
            slow_dt: b.2,
            slow_samples: b.3,
            probe_seconds: b.4,
            planned_seconds: b.5,
        })
}

/// Any board reply.
pub(crate) fn board_message() -> impl Strategy<Value = BoardMessage> {
    let stage = select(vec![
        JobStage::Experiment,
        JobStage::Search,
        JobStage::Refine,
        JobStage::Check,
        JobStage::Probe,
    ]);
    let not_stored = prop_oneof![
        select(vec![NotStored::Empty, NotStored::Corrupt]),
        any::<u16>().prop_map(|found| NotStored::OtherLayout { found }),
    ];
    prop_oneof![
        (any::<u16>(), any::<u32>()).prop_map(|(version, max_samples)| BoardMessage::Hello {
            version,
            max_samples
        }),
        refusal().prop_map(BoardMessage::Refused),
        any::<u32>().prop_map(|next| BoardMessage::ChunkOk { next }),
        (stage, any::<u32>(), any::<u32>(), any::<u32>(), float()).prop_map(
            |(stage, iteration, total, evaluations, best)| BoardMessage::Progress {
                stage,
                iteration,
                total,
                evaluations,
                best,
            }
        ),
        motor_report().prop_map(BoardMessage::Identified),
        plan().prop_map(BoardMessage::Planned),
        prop_oneof![motor_report().prop_map(Ok), not_stored.prop_map(Err)]
            .prop_map(BoardMessage::Params),
        Just(BoardMessage::Cleared),
        Just(BoardMessage::Aborted),
        limits().prop_map(BoardMessage::Limits),
        record_part().prop_map(BoardMessage::RecordData),
    ]
}

/// Any part of a record (any numbers and lengths, as a corrupt or hostile board may send).
fn record_part() -> impl Strategy<Value = RecordPart> {
    let samples = || vec(float(), 0..=READ_CHUNK).prop_map(heapless_vec);
    (
        (any::<u8>(), any::<u8>(), float(), any::<u32>()),
        (
            proptest::option::of(any::<u32>()),
            any::<u32>(),
            any::<u32>(),
        ),
        (samples(), samples(), samples()),
    )
        .prop_map(
            |(
                (record, records, dt, total),
                (coast_from, averaged, offset),
                (v, omega, current),
            )| {
                RecordPart {
                    record,
                    records,
                    dt,
                    samples: total,
                    coast_from,
                    averaged,
                    offset,
                    v,
                    omega,
                    current,
                }
            },
        )
}
