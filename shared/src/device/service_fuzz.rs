//! Fuzz target `service` (the harness is described in the `motor-id-fuzz` crate, the seeds
//! are in `fuzz/corpus/service/`): the board's request handler, [`Service`], fed arbitrary
//! sequences of [`HostMessage`] through the test link of the service tests, some arriving
//! while a job runs, on the simulated plant. The sequences are generated structurally
//! (hellos of any version, announcements within and beyond the capacity, chunks in and out
//! of order, at wrong offsets and of mismatched lengths, whole uploads of a motor's record or
//! of arbitrary numbers, identifications with every pipeline, commissioning, aborts) or are
//! the seed sessions with requests dropped, repeated, swapped or replaced. It checks that
//!
//! - the service never panics;
//! - every request is answered, within a bounded number of link polls and watchdog feeds:
//!   a request during a job with `Busy` (an `Abort` ends the job instead), every other one
//!   with exactly one final reply, and only jobs send progress;
//! - each final reply is the one the protocol (docs/CONTRACTS.md, "Exchange rules") gives
//!   for the request in the state the earlier replies left: the session of the last hello,
//!   the chunk count acknowledged, the parameters commissioning stored;
//! - afterwards the board is serviceable: a hello is answered with a hello, and a new
//!   record is taken.

use super::*;
use crate::model::profile::Profile;
use crate::model::synth::Noise;
use crate::testkit::Owned;
use crate::wire::arbitrary::{float, host_message, pipeline};
use crate::wire::frame::{encode, Decoder, MAX_FRAME};
use crate::wire::protocol::CHUNK;
use motor_id_fuzz::{check, corpus, corpus_dir};
use proptest::collection::vec;
use proptest::prelude::*;
use proptest::sample::Index;
use proptest::test_runner::{TestCaseError, TestCaseResult};

/// Samples the fuzzed board holds: small, so that each identification is quick.
const CAPACITY: usize = 64;

/// Cases in the default run (each a session of up to a few dozen requests).
const CASES: u32 = 256;

/// Link polls plus watchdog feeds that one request may take. A job on a record of
/// [`CAPACITY`] takes about 400 (one of each per optimiser iteration); commissioning feeds
/// once per drive sample and polls every tenth of a second over at most its time budget
/// (60,000 samples of the tests' 1 kHz drive), and its fit of two records takes some
/// thousands more: only a runaway loop reaches this.
const STEP_BOUND: u32 = 90_000;

/// Step of the records uploaded [s].
const DT: f32 = 0.01;

/// Sensor noise of the records uploaded.
const NOISE: Noise = Noise {
    omega: 0.5,
    current: 0.02,
};

/// What the earlier replies say of the board's state.
struct Model {
    /// A hello of this version was answered with a hello, and no other hello since.
    session: bool,
    /// The record being received, when the replies tell it (not after commissioning, which
    /// records into the same buffers).
    upload: Option<Upload>,
    /// The parameters stored (by a successful commissioning), if any.
    stored: Option<MotorReport>,
    /// The limits commissioning works within (the last usable ones the host set).
    limits: Limits,
}

#[derive(Clone, Copy)]
struct Upload {
    announced: usize,
    next: usize,
    with_current: bool,
}

impl Model {
    /// A board at power-up with nothing stored (an empty record store announces nothing).
    fn new() -> Model {
        Model {
            session: false,
            upload: Some(Upload {
                announced: 0,
                next: 0,
                with_current: false,
            }),
            stored: None,
            limits: LIMITS,
        }
    }

    /// The reply to chunk `v, omega, current` at `offset`: `Some(next)` for `ChunkOk`,
    /// `None` for `BadChunk`. It must start at the count received so far, with columns of
    /// one length (no current when the record has none), within the announced length; a
    /// chunk that ends at the count received (a repeat of the last) is acknowledged again.
    fn chunk(&self, offset: u32, v: usize, omega: usize, current: usize) -> Option<Option<usize>> {
        let u = self.upload?;
        let offset = offset as usize;
        Some(if v > 0 && offset + v == u.next {
            Some(u.next)
        } else if offset == u.next
            && omega == v
            && (!u.with_current || current == v)
            && u.next + v <= u.announced
        {
            Some(u.next + v)
        } else {
            None
        })
    }

    /// Check the replies of one turn of the service loop, in which `received` came in (the
    /// request, then those that arrived during its job), and update the model.
    fn turn(&mut self, received: &[HostMessage], sent: &[BoardMessage]) -> TestCaseResult {
        let Some((request, during)) = received.split_first() else {
            prop_assert!(sent.is_empty(), "unasked: {sent:?}");
            return Ok(());
        };
        // Progress, and a commissioning's plan, come before the final reply.
        let progress = |m: &&BoardMessage| {
            matches!(m, BoardMessage::Progress { .. } | BoardMessage::Planned(_))
        };
        let finals: Vec<&BoardMessage> = sent.iter().filter(|m| !progress(m)).collect();
        let aborted = during.last() == Some(&HostMessage::Abort);
        let busy = during.len() - usize::from(aborted);
        prop_assert!(
            during[..busy].iter().all(|m| *m != HostMessage::Abort),
            "requests taken after an abort: {during:?}"
        );
        prop_assert_eq!(
            finals.len(),
            busy + 1,
            "replies to {:?}: {:?}",
            received,
            sent
        );
        let busy_reply = BoardMessage::Refused(Refusal::Busy);
        prop_assert!(
            finals[..busy].iter().all(|m| **m == busy_reply),
            "{finals:?}"
        );
        let reply = finals[busy];
        let job = !during.is_empty() || sent.len() > finals.len();
        if job {
            let is_job = matches!(
                request,
                HostMessage::Identify { .. } | HostMessage::Commission { .. }
            );
            prop_assert!(self.session && is_job, "progress or busy for {request:?}");
        }
        if aborted {
            prop_assert_eq!(reply, &BoardMessage::Aborted);
        }
        self.reply(request, reply)
    }

    /// Check the final reply to `request` and update the model.
    fn reply(&mut self, request: &HostMessage, reply: &BoardMessage) -> TestCaseResult {
        use BoardMessage as B;
        use HostMessage as H;
        let refused = |r: Refusal| B::Refused(r);
        let fail = || {
            Err(TestCaseError::fail(format!(
                "{request:?} answered {reply:?}"
            )))
        };
        if let H::Hello { version } = *request {
            self.session = version == PROTOCOL_VERSION;
            let want = if self.session {
                B::Hello {
                    version: PROTOCOL_VERSION,
                    max_samples: CAPACITY as u32,
                }
            } else {
                refused(Refusal::VersionMismatch {
                    board: PROTOCOL_VERSION,
                })
            };
            prop_assert_eq!(reply, &want);
            return Ok(());
        }
        if !self.session {
            prop_assert_eq!(reply, &refused(Refusal::NoSession), "{:?}", request);
            return Ok(());
        }
        match request {
            H::Hello { .. } => unreachable!("answered above"),
            H::IdentifyBegin {
                samples,
                with_current,
                coast_from,
                ..
            } => {
                if *samples as usize > CAPACITY {
                    let max = CAPACITY as u32;
                    prop_assert_eq!(reply, &refused(Refusal::RecordTooLong { max }));
                } else if coast_from.is_some_and(|k| k >= *samples) {
                    prop_assert_eq!(reply, &refused(Refusal::BadChunk));
                } else {
                    prop_assert_eq!(reply, &B::ChunkOk { next: 0 });
                    self.upload = Some(Upload {
                        announced: *samples as usize,
                        next: 0,
                        with_current: *with_current,
                    });
                }
            }
            H::RecordChunk {
                offset,
                v,
                omega,
                current,
            } => {
                let got = match reply {
                    B::ChunkOk { next } => Some(*next as usize),
                    B::Refused(Refusal::BadChunk) => None,
                    _ => return fail(),
                };
                let want = self.chunk(*offset, v.len(), omega.len(), current.len());
                if let (Some(u), Some(want)) = (self.upload.as_mut(), want) {
                    prop_assert_eq!(got, want, "{:?}", request);
                    u.next = got.unwrap_or(u.next);
                }
            }
            H::Identify { .. } => {
                let complete = self.upload.map(|u| u.next == u.announced && u.next > 0);
                let ran = match reply {
                    B::Identified(report) => check_report(report).map(|_| true)?,
                    B::Refused(Refusal::InvalidRecord | Refusal::PipelineTooLarge) => true,
                    B::Aborted => true,
                    B::Refused(Refusal::BadChunk) => false,
                    _ => return fail(),
                };
                if let Some(complete) = complete {
                    prop_assert_eq!(ran, complete, "{:?} answered {:?}", request, reply);
                }
            }
            H::Commission { .. } => {
                self.upload = None;
                match reply {
                    B::Identified(report) => {
                        check_report(report)?;
                        self.stored = Some(report.clone());
                    }
                    B::Aborted
                    | B::Refused(
                        Refusal::Trip
                        | Refusal::NotAtRest
                        | Refusal::SensorFault
                        | Refusal::NoMotion
                        | Refusal::TooFast
                        | Refusal::NoBackEmf
                        | Refusal::InvalidRecord,
                    ) => {}
                    _ => return fail(),
                }
            }
            H::ReadParams => {
                let want = B::Params(self.stored.clone().ok_or(NotStored::Empty));
                // Debug, not ==: a report that does not pin a parameter holds a NaN.
                prop_assert_eq!(format!("{reply:?}"), format!("{want:?}"));
            }
            H::ClearParams => {
                prop_assert_eq!(reply, &B::Cleared);
                self.stored = None;
            }
            H::Abort => prop_assert_eq!(reply, &B::Aborted),
            H::Configure(limits) => {
                if limits.usable() {
                    prop_assert_eq!(reply, &B::Limits(*limits));
                    self.limits = *limits;
                } else {
                    prop_assert_eq!(reply, &refused(Refusal::BadLimits));
                }
            }
            H::ReadLimits => prop_assert_eq!(reply, &B::Limits(self.limits)),
            H::ReadRecord { record, offset } => match reply {
                B::RecordData(part) => {
                    let (n, left) = (part.v.len(), part.samples.saturating_sub(*offset));
                    prop_assert!(part.record == *record && part.offset == *offset);
                    prop_assert!(*record < part.records && *offset < part.samples);
                    prop_assert_eq!(n, (left as usize).min(READ_CHUNK));
                    prop_assert_eq!(part.omega.len(), n);
                    prop_assert!(part.current.is_empty() || part.current.len() == n);
                }
                B::Refused(Refusal::NoRecord) => {}
                _ => return fail(),
            },
        }
        Ok(())
    }
}

/// A report holds the five motor parameters, each a finite number.
fn check_report(report: &MotorReport) -> TestCaseResult {
    for id in ParamId::MOTOR {
        let e = report.get(id.index() as u8);
        prop_assert!(e.is_some_and(|e| e.value.is_finite()), "{report:?}");
    }
    Ok(())
}

/// Play `requests` (each after a gap of so many link polls) to a fresh board, checking every
/// turn, then check that the board is still serviceable.
fn play(requests: &[(u32, HostMessage)]) -> TestCaseResult {
    let mut store = RecordStore::<CAPACITY>::new();
    let mut service = Service::new(&mut store, LIMITS);
    let mut hw = hardware(paper_plant());
    let mut at = 0;
    for (gap, msg) in requests {
        at += gap;
        hw.link.incoming.push_back((at, msg.clone()));
    }
    let mut model = Model::new();
    while !hw.link.incoming.is_empty() {
        let (received, sent) = (hw.link.received.len(), hw.link.sent.len());
        let steps = hw.link.polls + hw.watchdog.0;
        service.poll(&mut hw);
        let steps = hw.link.polls + hw.watchdog.0 - steps;
        prop_assert!(steps <= STEP_BOUND, "{steps} steps for one request");
        let link = &hw.link;
        model.turn(&link.received[received..], &link.sent[sent..])?;
    }
    // Serviceable: a hello is answered with a hello, and a new record is taken.
    let upload = upload(&Owned::paper_motor(Profile::Steps, DT, CHUNK, NOISE, 1));
    let hello = HostMessage::Hello {
        version: PROTOCOL_VERSION,
    };
    let mut model = Model::new();
    for msg in core::iter::once(hello).chain(upload) {
        let sent = hw.link.sent.len();
        service.handle(msg.clone(), &mut hw);
        model.reply(&msg, &hw.link.sent[sent])?;
        prop_assert_eq!(hw.link.sent.len(), sent + 1);
        prop_assert!(!matches!(hw.link.sent[sent], BoardMessage::Refused(_)));
    }
    Ok(())
}

/// The requests that stream `data` in (announcement, then every chunk in order), with
/// current.
fn upload(data: &Owned) -> Vec<HostMessage> {
    let n = data.v.len();
    let begin = HostMessage::IdentifyBegin {
        dt: data.dt,
        samples: n as u32,
        with_current: true,
        coast_from: None,
    };
    let chunk = |s: usize| {
        let e = (s + CHUNK).min(n);
        let col = |c: &[f32]| heapless::Vec::from_slice(&c[s..e]).unwrap();
        HostMessage::RecordChunk {
            offset: s as u32,
            v: col(&data.v),
            omega: col(&data.omega),
            current: col(&data.current),
        }
    };
    core::iter::once(begin)
        .chain((0..n).step_by(CHUNK).map(chunk))
        .collect()
}

/// A step of a generated session.
#[derive(Clone, Debug)]
enum Step {
    /// One request as generated.
    Request(HostMessage),
    /// A whole upload of `samples` of the paper's motor's response (noise seed `seed`), or of
    /// arbitrary numbers, then an identification with `pipeline`.
    Upload {
        samples: usize,
        seed: u64,
        arbitrary: Option<Vec<f32>>,
        pipeline: PipelineName,
    },
}

impl Step {
    fn requests(&self) -> Vec<HostMessage> {
        let (samples, seed, arbitrary, pipeline) = match self {
            Step::Request(msg) => return vec![msg.clone()],
            Step::Upload {
                samples,
                seed,
                arbitrary,
                pipeline,
            } => (*samples, *seed, arbitrary, *pipeline),
        };
        let mut data = Owned::paper_motor(Profile::Steps, DT, samples, NOISE, seed);
        if let Some(values) = arbitrary {
            let columns = [&mut data.v, &mut data.omega, &mut data.current];
            for (k, x) in columns.into_iter().flat_map(|c| c.iter_mut()).enumerate() {
                *x = values[k % values.len()];
            }
        }
        let mut requests = upload(&data);
        requests.push(HostMessage::Identify { seed, pipeline });
        requests
    }
}

fn step() -> impl Strategy<Value = Step> {
    let upload = (
        crate::model::record::MIN_SAMPLES..=CAPACITY,
        any::<u64>(),
        proptest::option::of(vec(float(), 1..8)),
        pipeline(),
    )
        .prop_map(|(samples, seed, arbitrary, pipeline)| Step::Upload {
            samples,
            seed,
            arbitrary,
            pipeline,
        });
    prop_oneof![
        12 => host_message(CAPACITY as u32).prop_map(Step::Request),
        1 => upload,
    ]
}

/// A generated session: steps, each after a gap of 0 to 3 polls (a gap lets a request
/// arrive during the job before it, or after it).
fn generated() -> impl Strategy<Value = Vec<(u32, HostMessage)>> {
    vec((0..4u32, step()), 0..24).prop_map(|steps| {
        let mut out = Vec::new();
        for (gap, step) in steps {
            for (k, msg) in step.requests().into_iter().enumerate() {
                out.push((if k == 0 { gap } else { 0 }, msg));
            }
        }
        out
    })
}

/// The requests in a stream of frames.
fn requests_in(stream: &[u8]) -> Vec<HostMessage> {
    let mut d = Decoder::new();
    let decoded = stream.iter().filter_map(|b| d.push::<HostMessage>(*b));
    decoded.map(|r| r.expect("seed frames decode")).collect()
}

/// An edit of a seed session.
#[derive(Clone, Debug)]
enum Edit {
    Drop(Index),
    Repeat(Index),
    Swap(Index, Index),
    Replace(Index, HostMessage),
    Insert(Index, HostMessage),
    Delay(Index, u32),
}

/// A seed session with up to six edits.
fn mutated_seed(seeds: Vec<Vec<HostMessage>>) -> impl Strategy<Value = Vec<(u32, HostMessage)>> {
    let i = any::<Index>;
    let msg = || host_message(CAPACITY as u32);
    let edit = prop_oneof![
        i().prop_map(Edit::Drop),
        i().prop_map(Edit::Repeat),
        (i(), i()).prop_map(|(a, b)| Edit::Swap(a, b)),
        (i(), msg()).prop_map(|(a, m)| Edit::Replace(a, m)),
        (i(), msg()).prop_map(|(a, m)| Edit::Insert(a, m)),
        (i(), 1..4u32).prop_map(|(a, gap)| Edit::Delay(a, gap)),
    ];
    (0..seeds.len(), vec(edit, 0..=6)).prop_map(move |(k, edits)| {
        let mut s: Vec<(u32, HostMessage)> = seeds[k].iter().map(|m| (0, m.clone())).collect();
        for e in edits {
            if s.is_empty() {
                break;
            }
            let n = s.len();
            let at = |i: &Index| i.index(n);
            match e {
                Edit::Drop(a) => drop(s.remove(at(&a))),
                Edit::Repeat(a) => s.insert(at(&a), s[at(&a)].clone()),
                Edit::Swap(a, b) => s.swap(at(&a), at(&b)),
                Edit::Replace(a, m) => s[at(&a)].1 = m,
                Edit::Insert(a, m) => s.insert(at(&a), (0, m)),
                Edit::Delay(a, gap) => s[at(&a)].0 = gap,
            }
        }
        s
    })
}

fn seed_sessions() -> Vec<(String, Vec<HostMessage>)> {
    let seeds = corpus("service").into_iter();
    seeds.map(|s| (s.name, requests_in(&s.bytes))).collect()
}

#[test]
fn replays_the_seed_corpus() {
    for (name, requests) in seed_sessions() {
        assert!(!requests.is_empty(), "{name}: no request");
        let timed: Vec<_> = requests.into_iter().map(|m| (0, m)).collect();
        if let Err(e) = play(&timed) {
            panic!("{name}: {e}");
        }
    }
}

#[test]
fn any_request_sequence_is_answered_by_the_protocol() {
    let seeds = seed_sessions().into_iter().map(|s| s.1).collect();
    let input = prop_oneof![generated(), mutated_seed(seeds)];
    check("service", CASES, &input, |requests| play(&requests));
}

/// Write the seed corpus of `service`: sessions of host requests as the host frames them.
/// Run by hand when the protocol changes:
/// `cargo test -p motor-id-shared --features std,full write_service_corpus -- --ignored`.
#[test]
#[ignore = "writes fuzz/corpus/service"]
fn write_service_corpus() {
    let hello = HostMessage::Hello {
        version: PROTOCOL_VERSION,
    };
    let data = Owned::paper_motor(Profile::Steps, DT, CAPACITY, NOISE, 3);
    let mut records = upload(&data);
    let identify = |pipeline| HostMessage::Identify { seed: 1, pipeline };
    let with = |tail: &[HostMessage]| {
        let mut s = vec![hello.clone()];
        s.extend_from_slice(tail);
        s
    };
    let mut out_of_order = records.clone();
    out_of_order.swap(1, 2);
    let sessions: Vec<(&str, Vec<HostMessage>)> = vec![
        ("identify-board", {
            records.push(identify(PipelineName::Board));
            with(&records)
        }),
        ("identify-then-abort", {
            records.pop();
            records.push(identify(PipelineName::Default));
            records.push(HostMessage::Abort);
            with(&records)
        }),
        ("chunks-out-of-order", with(&out_of_order)),
        (
            "commission-read-clear",
            with(&[
                HostMessage::Commission { seed: 1 },
                HostMessage::ReadParams,
                HostMessage::ClearParams,
                HostMessage::ReadParams,
            ]),
        ),
        (
            "version-mismatch",
            vec![
                HostMessage::ReadParams,
                HostMessage::Hello {
                    version: PROTOCOL_VERSION + 1,
                },
                HostMessage::ReadParams,
                hello.clone(),
            ],
        ),
        (
            "record-too-long",
            with(&[HostMessage::IdentifyBegin {
                dt: DT,
                samples: u32::MAX,
                with_current: false,
                coast_from: None,
            }]),
        ),
    ];
    let dir = corpus_dir("service");
    std::fs::create_dir_all(&dir).unwrap();
    for (name, requests) in sessions {
        let mut stream = Vec::new();
        let mut out = [0u8; MAX_FRAME];
        for m in &requests {
            stream.extend_from_slice(encode(m, &mut out).unwrap());
        }
        std::fs::write(dir.join(format!("{name}.bin")), stream).unwrap();
    }
}
