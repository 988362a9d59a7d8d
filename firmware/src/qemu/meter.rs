//! Footprint meter of the QEMU build: SysTick ticks spent from a request to identify
//! (`Identify`, or `Commission`: experiment and identification) until its result, the ticks
//! of the identification alone (from the drive's stop at the end of a commissioning
//! experiment; the whole job for `Identify`), and the stack high-water mark (the stack is
//! painted at reset by cortex-m-rt's `paint-stack`). Under `qemu-system-arm -icount shift=0`
//! one instruction advances the virtual clock by 1 ns and SysTick (168 MHz) by 0.168 ticks,
//! so the tick count is a deterministic instruction count. One plain-text line per job goes
//! to semihosting stderr (defmt's binary log is on stdout):
//! `footprint: job=identify|commission|power-up ticks=T fit_ticks=F stack_bytes=S samples=N`
//! (`samples` of the last record streamed in; a commissioning records its own). `power-up`
//! is the commissioning a board without parameters runs at reset, metered from reset while
//! the host sends nothing; one that ends without parameters (refused or aborted) prints
//! `footprint: job=power-up outcome=no-parameters`.

use core::cell::Cell;
use core::sync::atomic::{AtomicU32, Ordering};
use cortex_m::interrupt::{self, Mutex};
use cortex_m::peripheral::{syst::SystClkSource, SYST};
use cortex_m_rt::exception;
use motor_id_shared::device::hardware::{Drive, Link, Sample};
use motor_id_shared::wire::protocol::{BoardMessage, HostMessage};

/// When the drive was last stopped [ticks] (the end of a commissioning experiment).
static DRIVE_STOPPED: Mutex<Cell<u64>> = Mutex::new(Cell::new(0));

/// SysTick wraps (every 2^24 ticks).
static WRAPS: AtomicU32 = AtomicU32::new(0);
const RELOAD: u32 = 0x00FF_FFFF;

#[exception]
fn SysTick() {
    WRAPS.fetch_add(1, Ordering::Relaxed);
}

/// Run SysTick freely from the core clock, counting wraps.
pub fn start(mut syst: SYST) {
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(RELOAD);
    syst.clear_current();
    syst.enable_interrupt();
    syst.enable_counter();
    // The counter keeps running when `syst` goes; reads go through `SYST::get_current`.
}

/// Ticks since [`start`].
fn now() -> u64 {
    loop {
        let before = WRAPS.load(Ordering::Relaxed);
        let current = SYST::get_current();
        if WRAPS.load(Ordering::Relaxed) == before {
            return before as u64 * (RELOAD as u64 + 1) + (RELOAD - current) as u64;
        }
    }
}

/// Deepest stack use since reset [bytes]: painted words still intact are unused.
fn stack_high_water() -> u32 {
    extern "C" {
        static _stack_end: u32;
        static _stack_start: u32;
    }
    // SAFETY: the linker script's stack bounds; the words between them are plain RAM.
    unsafe {
        let bottom = core::ptr::addr_of!(_stack_end);
        let top = core::ptr::addr_of!(_stack_start);
        let mut p = bottom;
        while p < top && core::ptr::read_volatile(p) == cortex_m_rt::STACK_PAINT_VALUE {
            p = p.add(1);
        }
        (top as u32) - (p as u32)
    }
}

/// The kind of a metered job.
#[derive(Clone, Copy, PartialEq)]
enum Job {
    /// A record streamed in and identified.
    Identify,
    /// A commissioning the host asked for.
    Commission,
    /// The commissioning at reset of a board without parameters, metered while the host
    /// stays silent (none runs where valid ones are stored: the first message ends it).
    PowerUp,
}

impl Job {
    fn name(self) -> &'static str {
        match self {
            Job::Identify => "identify",
            Job::Commission => "commission",
            Job::PowerUp => "power-up",
        }
    }
}

/// A link that meters the jobs it carries.
pub struct MeteredLink<L> {
    inner: L,
    /// Start of the running job and its kind.
    started: Option<(u64, Job)>,
    samples: u32,
}

impl<L> MeteredLink<L> {
    /// Meter `inner`, from reset: a power-up commissioning, if the board runs one, is the
    /// first job.
    pub fn new(inner: L) -> Self {
        MeteredLink {
            inner,
            started: Some((now(), Job::PowerUp)),
            samples: 0,
        }
    }
}

impl<L: Link> Link for MeteredLink<L> {
    fn send(&mut self, msg: &BoardMessage) {
        let done = matches!(msg, BoardMessage::Identified(_));
        let ended = matches!(msg, BoardMessage::Refused(_) | BoardMessage::Aborted);
        if let Some((_, Job::PowerUp)) = self.started.filter(|_| ended) {
            self.started = None;
            cortex_m_semihosting::heprintln!("footprint: job=power-up outcome=no-parameters");
        }
        if let Some((t0, job)) = self.started.filter(|_| done) {
            self.started = None;
            let end = now();
            let fit_from = match job {
                Job::Identify => t0,
                Job::Commission | Job::PowerUp => {
                    interrupt::free(|cs| DRIVE_STOPPED.borrow(cs).get()).max(t0)
                }
            };
            cortex_m_semihosting::heprintln!(
                "footprint: job={} ticks={} fit_ticks={} stack_bytes={} samples={}",
                job.name(),
                end - t0,
                end - fit_from,
                stack_high_water(),
                self.samples
            );
        }
        self.inner.send(msg);
    }

    fn poll(&mut self) -> Option<HostMessage> {
        let msg = self.inner.poll();
        if msg.is_some() && matches!(self.started, Some((_, Job::PowerUp))) {
            // A host that talks during the power-up commissioning meters its own jobs: the
            // power-up's is not reported (a reply to the host would be taken for its end).
            self.started = None;
        }
        match &msg {
            Some(HostMessage::IdentifyBegin { samples, .. }) => self.samples = *samples,
            Some(HostMessage::Identify { .. }) => self.started = Some((now(), Job::Identify)),
            Some(HostMessage::Commission { .. }) => self.started = Some((now(), Job::Commission)),
            _ => {}
        }
        msg
    }
}

/// A drive that notes when it is stopped (see [`DRIVE_STOPPED`]).
pub struct MeteredDrive<D>(pub D);

impl<D: Drive> Drive for MeteredDrive<D> {
    fn dt(&self) -> f32 {
        self.0.dt()
    }
    fn step(&mut self, volts: f32) -> Sample {
        self.0.step(volts)
    }
    fn coast(&mut self) -> Sample {
        self.0.coast()
    }
    fn stop(&mut self) {
        self.0.stop();
        let t = now();
        interrupt::free(|cs| DRIVE_STOPPED.borrow(cs).set(t));
    }
}
