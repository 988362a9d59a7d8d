//! The power stage and its sensors: TIM1 PWM on the two legs of the H-bridge, and ADC1
//! converting tacho and armature current at every TIM2 update (fixed rate), the pair moved
//! by DMA2 stream 0 into one of two buffers while the other is read. [`Drive::step`] waits
//! for the next pair, so the experiment runs at the ADC's rate.

use motor_id_shared::device::hardware::{Drive, Sample};
use stm32f4xx_hal::adc::config::{
    AdcConfig, Dma, ExternalTrigger, SampleTime, Scan, Sequence, TriggerMode,
};
use stm32f4xx_hal::adc::Adc;
use stm32f4xx_hal::dma::config::DmaConfig;
use stm32f4xx_hal::dma::{DMAError, PeripheralToMemory, Stream0, StreamsTuple, Transfer};
use stm32f4xx_hal::gpio::{Analog, Output, Pin};
use stm32f4xx_hal::pac::{self, ADC1, DMA2};
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::rcc::Rcc;
use stm32f4xx_hal::timer::{CounterHz, PwmChannel, PwmHzManager};

/// Sample rate of tacho and current [Hz]: one ADC pair per PWM period. Commissioning's probe
/// reads the motor at this rate and averages it into its records' steps.
pub const SAMPLE_HZ: u32 = 20_000;
/// PWM frequency of the bridge [Hz].
const PWM_HZ: u32 = 20_000;
/// DC bus voltage [V]: the duty cycle is |v| / BUS_VOLTS.
const BUS_VOLTS: f32 = 60.0;
/// ADC full scale [V] and counts.
const ADC_VOLTS: f32 = 3.3;
const ADC_COUNTS: f32 = 4096.0;
/// Tacho: rad/s per volt at the ADC pin, and the pin voltage at standstill (bipolar tacho
/// biased to mid-scale).
const TACHO_RAD_S_PER_V: f32 = 350.0;
const TACHO_ZERO_V: f32 = 1.65;
/// Current amplifier: amps per volt at the ADC pin, and the pin voltage at 0 A.
const CURRENT_A_PER_V: f32 = 25.0;
const CURRENT_ZERO_V: f32 = 1.65;

type Buffer = &'static mut [u16; 2];
type SampleTransfer = Transfer<Stream0<DMA2>, 0, Adc<ADC1>, PeripheralToMemory, Buffer>;

/// What the drive takes over.
pub struct Peripherals {
    /// PWM timer.
    pub tim1: pac::TIM1,
    /// Sample-rate timer (its update event triggers the ADC).
    pub tim2: pac::TIM2,
    /// The ADC.
    pub adc1: ADC1,
    /// Its DMA.
    pub dma2: DMA2,
    /// Leg A of the bridge (TIM1 CH1).
    pub leg_a: Pin<'A', 8>,
    /// Leg B of the bridge (TIM1 CH2).
    pub leg_b: Pin<'A', 9>,
    /// Bridge enable.
    pub enable: Pin<'B', 0, Output>,
    /// Tacho input.
    pub tacho: Pin<'A', 0, Analog>,
    /// Current input.
    pub current: Pin<'A', 1, Analog>,
}

/// The drive board's [`Drive`].
pub struct BoardDrive {
    _pwm: PwmHzManager<pac::TIM1>,
    leg_a: PwmChannel<pac::TIM1, 0>,
    leg_b: PwmChannel<pac::TIM1, 1>,
    enable: Pin<'B', 0, Output>,
    transfer: SampleTransfer,
    spare: Option<Buffer>,
    _sample_timer: CounterHz<pac::TIM2>,
}

fn pin_volts(raw: u16) -> f32 {
    raw as f32 * (ADC_VOLTS / ADC_COUNTS)
}

/// The sensor readings of one ADC pair.
fn reading(tacho: u16, current: u16) -> Sample {
    Sample {
        omega: (pin_volts(tacho) - TACHO_ZERO_V) * TACHO_RAD_S_PER_V,
        current: (pin_volts(current) - CURRENT_ZERO_V) * CURRENT_A_PER_V,
    }
}

impl BoardDrive {
    /// Configure PWM (bridge disabled), ADC, DMA and the sample timer, and start sampling.
    pub fn new(p: Peripherals, rcc: &mut Rcc) -> Self {
        let mut enable = p.enable;
        enable.set_low();
        let (pwm, (ch1, ch2, ..)) = p.tim1.pwm_hz(PWM_HZ.Hz(), rcc);
        let mut leg_a = ch1.with(p.leg_a);
        let mut leg_b = ch2.with(p.leg_b);
        leg_a.set_duty(0);
        leg_b.set_duty(0);
        leg_a.enable();
        leg_b.enable();

        let config = AdcConfig::default()
            .dma(Dma::Continuous)
            .scan(Scan::Enabled)
            .external_trigger(TriggerMode::RisingEdge, ExternalTrigger::Tim_2_trgo);
        let mut adc = Adc::new(p.adc1, true, config, rcc);
        adc.configure_channel(&p.tacho, Sequence::One, SampleTime::Cycles_84);
        adc.configure_channel(&p.current, Sequence::Two, SampleTime::Cycles_84);

        let streams = StreamsTuple::new(p.dma2, rcc);
        let first = cortex_m::singleton!(: [u16; 2] = [0; 2]).expect("once");
        let second = cortex_m::singleton!(: [u16; 2] = [0; 2]).expect("once");
        let spare = cortex_m::singleton!(: [u16; 2] = [0; 2]).expect("once");
        let dma = DmaConfig::default()
            .memory_increment(true)
            .double_buffer(true);
        let mut transfer =
            Transfer::init_peripheral_to_memory(streams.0, adc, first, Some(second), dma);
        transfer.start(|_| {});

        // TIM2 update at SAMPLE_HZ, its update event as TRGO (MMS = 010) for the ADC.
        let mut timer = p.tim2.counter_hz(rcc);
        timer
            .start(SAMPLE_HZ.Hz())
            .expect("sample rate within TIM2's range");
        // SAFETY: TIM2 is owned by `timer` (kept in the drive), which never writes CR2.
        unsafe { (*pac::TIM2::ptr()).cr2().modify(|_, w| w.mms().update()) };

        BoardDrive {
            _pwm: pwm,
            leg_a,
            leg_b,
            enable,
            transfer,
            spare: Some(spare),
            _sample_timer: timer,
        }
    }

    /// The next tacho/current pair from the DMA (waits for it).
    fn next_pair(&mut self) -> [u16; 2] {
        let mut spare = self.spare.take().expect("a spare buffer between samples");
        loop {
            match self.transfer.next_transfer(spare) {
                Ok((filled, _)) => {
                    let pair = *filled;
                    self.spare = Some(filled);
                    return pair;
                }
                Err(DMAError::NotReady(b)) => spare = b,
                Err(DMAError::Overrun(b) | DMAError::SmallBuffer(b)) => {
                    // A sample was lost: restart the stream on the next pair.
                    defmt::warn!("ADC DMA overrun: a sample was lost");
                    spare = b;
                }
            }
        }
    }
}

impl Drive for BoardDrive {
    fn dt(&self) -> f32 {
        1.0 / SAMPLE_HZ as f32
    }

    fn step(&mut self, volts: f32) -> Sample {
        let [tacho, current] = self.next_pair();
        let max = self.leg_a.get_max_duty() as f32;
        let duty = ((volts.abs() / BUS_VOLTS).min(1.0) * max) as u16;
        if volts >= 0.0 {
            self.leg_b.set_duty(0);
            self.leg_a.set_duty(duty);
        } else {
            self.leg_a.set_duty(0);
            self.leg_b.set_duty(duty);
        }
        self.enable.set_high();
        reading(tacho, current)
    }

    fn coast(&mut self) -> Sample {
        let [tacho, current] = self.next_pair();
        self.stop();
        reading(tacho, current)
    }

    fn stop(&mut self) {
        self.leg_a.set_duty(0);
        self.leg_b.set_duty(0);
        self.enable.set_low();
    }
}
