//! The STM32F405 drive-board layer. Pin map (a common open drive-board layout; change it
//! here for another board):
//!
//! | function | pin | peripheral |
//! |---|---|---|
//! | H-bridge PWM, leg A / leg B | PA8 / PA9 | TIM1 CH1 / CH2, 20 kHz |
//! | H-bridge enable (low: all switches off, the motor coasts) | PB0 | GPIO |
//! | tacho / armature current | PA0 / PA1 | ADC1 IN0 / IN1, triggered by TIM2 TRGO, DMA2 stream 0 |
//! | host link | PB6 (TX) / PB7 (RX) | USART1, 115200 8N1 |
//! | status LED (lit: in service with valid parameters) | PC13 | GPIO |
//!
//! The parameters live in flash sector 11 (0x080E_0000, 128 KB), which `memory.x` keeps out
//! of the program's reach. The independent watchdog runs from power-up with a 500 ms
//! timeout; the application feeds it at every sample and every optimiser iteration.

mod drive;
mod flash;

use crate::app::{State, StatusLed};
use crate::link::{ByteSerial, SerialLink};
use defmt_rtt as _;
use motor_id_shared::device::flash_store::FlashStore;
use motor_id_shared::device::hardware::{Hardware, Watchdog};
use panic_probe as _;
use stm32f4xx_hal::gpio::{Output, Pin};
use stm32f4xx_hal::pac;
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::rcc::Config;
use stm32f4xx_hal::serial::Serial;
use stm32f4xx_hal::watchdog::IndependentWatchdog;

/// Crystal of the board.
const HSE_MHZ: u32 = 8;
/// Baud rate of the host link.
const BAUD: u32 = 115_200;
/// Longest window the IWDG can time [ms] (LSI 32 kHz, prescaler 256, reload 4095; the
/// HAL refuses 32,768 and above).
const LONGEST_WINDOW_MS: u32 = 32_767;
/// Watchdog timeout.
const WATCHDOG_MS: u32 = 500;

/// USART1, byte by byte.
pub struct HostSerial(Serial<pac::USART1>);

impl ByteSerial for HostSerial {
    fn write(&mut self, byte: u8) {
        // A polled transmitter cannot fail.
        let _ = nb::block!(embedded_hal_nb::serial::Write::write(&mut self.0, byte));
    }

    fn read(&mut self) -> Option<u8> {
        // Framing, noise and overrun errors lose the byte; the frame CRC catches the rest.
        embedded_hal_nb::serial::Read::read(&mut self.0).ok()
    }
}

/// The IWDG.
pub struct BoardWatchdog(IndependentWatchdog);

impl Watchdog for BoardWatchdog {
    fn feed(&mut self) {
        self.0.feed();
    }

    /// The window widened to twice the stall plus the usual one (the LSI that times the
    /// IWDG runs at 17 to 47 kHz, not 32: a window set in nominal milliseconds may pass
    /// 1.5 times faster), then the usual window again. Each change of window waits until
    /// the IWDG has taken it (its prescaler and reload updates done) before the feed that
    /// starts the count-down with it.
    fn stall(&mut self, up_to_ms: u32, op: &mut dyn FnMut()) {
        let wide = up_to_ms.saturating_mul(2).saturating_add(WATCHDOG_MS);
        self.window(wide.min(LONGEST_WINDOW_MS));
        op();
        self.window(WATCHDOG_MS);
    }
}

impl BoardWatchdog {
    /// Set the window to `ms` (at most [`LONGEST_WINDOW_MS`]) and restart the count-down
    /// with it.
    fn window(&mut self, ms: u32) {
        self.0.start(ms.millis());
        // SAFETY: a read of the IWDG's status register, which the HAL's watchdog owns and
        // never reads in between; no write.
        let iwdg = unsafe { &*stm32f4xx_hal::pac::IWDG::ptr() };
        while iwdg.sr().read().pvu().bit() || iwdg.sr().read().rvu().bit() {}
        self.0.feed();
    }
}

/// The status LED on PC13 (active low).
pub struct Led(Pin<'C', 13, Output>);

impl StatusLed for Led {
    fn show(&mut self, state: State) {
        match state {
            State::InService => self.0.set_low(),
            State::NoParameters => self.0.set_high(),
        }
    }
}

/// The board's hardware as the application sees it.
pub type BoardHardware =
    Hardware<SerialLink<HostSerial>, drive::BoardDrive, FlashStore<flash::Sector11>, BoardWatchdog>;

/// Clocks at 168 MHz, watchdog on, peripherals configured, drive off.
pub fn init() -> (BoardHardware, Led) {
    let dp = pac::Peripherals::take().expect("init runs once");
    let mut watchdog = IndependentWatchdog::new(dp.IWDG);
    watchdog.start(WATCHDOG_MS.millis());
    let mut rcc = dp.RCC.freeze(
        Config::hse(HSE_MHZ.MHz())
            .sysclk(168.MHz())
            .pclk1(42.MHz())
            .pclk2(84.MHz()),
    );
    let gpioa = dp.GPIOA.split(&mut rcc);
    let gpiob = dp.GPIOB.split(&mut rcc);
    let gpioc = dp.GPIOC.split(&mut rcc);
    let serial = dp
        .USART1
        .serial((gpiob.pb6, gpiob.pb7), BAUD.bps(), &mut rcc)
        .expect("valid USART1 configuration");
    let drive = drive::BoardDrive::new(
        drive::Peripherals {
            tim1: dp.TIM1,
            tim2: dp.TIM2,
            adc1: dp.ADC1,
            dma2: dp.DMA2,
            leg_a: gpioa.pa8,
            leg_b: gpioa.pa9,
            enable: gpiob.pb0.into_push_pull_output(),
            tacho: gpioa.pa0.into_analog(),
            current: gpioa.pa1.into_analog(),
        },
        &mut rcc,
    );
    let hw = Hardware {
        link: SerialLink::new(HostSerial(serial)),
        drive,
        params: FlashStore(flash::Sector11::new(dp.FLASH)),
        watchdog: BoardWatchdog(watchdog),
    };
    (hw, Led(gpioc.pc13.into_push_pull_output()))
}
