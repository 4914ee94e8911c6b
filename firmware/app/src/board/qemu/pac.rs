//! The mps2-an386 interrupt table; IRQs 16 and 17 are the executors' software interrupts.

/// External interrupts of the mps2-an386 used by the firmware.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u16)]
pub enum Interrupt {
    /// CMSDK UART0 receive.
    Uart0Rx = 0,
    /// CMSDK UART0 transmit.
    Uart0Tx = 1,
    /// CMSDK TIMER0 (the free-running build's tick).
    Timer0 = 8,
    /// Software interrupt: the control executor.
    Swi0 = 16,
    /// Software interrupt: the communication executor.
    Swi1 = 17,
}

// SAFETY: `number` is the interrupt's vector table position, below the 32 provided.
unsafe impl cortex_m::interrupt::InterruptNumber for Interrupt {
    fn number(self) -> u16 {
        self as u16
    }
}

/// One entry of the device vector table.
#[repr(C)]
pub union Vector {
    handler: unsafe extern "C" fn(),
    reserved: usize,
}

unsafe extern "C" {
    fn UART0RX();
    fn UART0TX();
    fn UART1RX();
    fn UART1TX();
    fn UART2RX();
    fn UART2TX();
    fn GPIO0();
    fn GPIO1();
    fn TIMER0();
    fn TIMER1();
    fn DUALTIMER();
    fn SPI();
    fn UARTOVF();
    fn ETHERNET();
    fn I2S();
    fn TOUCHSCREEN();
    fn SWI0();
    fn SWI1();
    fn DefaultHandler();
}

const fn h(handler: unsafe extern "C" fn()) -> Vector {
    Vector { handler }
}

/// The 32 external interrupt vectors, after the core exceptions (cortex-m-rt's `device`).
#[unsafe(link_section = ".vector_table.interrupts")]
#[unsafe(no_mangle)]
pub static __INTERRUPTS: [Vector; 32] = [
    h(UART0RX),
    h(UART0TX),
    h(UART1RX),
    h(UART1TX),
    h(UART2RX),
    h(UART2TX),
    h(GPIO0),
    h(GPIO1),
    h(TIMER0),
    h(TIMER1),
    h(DUALTIMER),
    h(SPI),
    h(UARTOVF),
    h(ETHERNET),
    h(I2S),
    h(TOUCHSCREEN),
    h(SWI0),
    h(SWI1),
    h(DefaultHandler),
    h(DefaultHandler),
    h(DefaultHandler),
    h(DefaultHandler),
    h(DefaultHandler),
    h(DefaultHandler),
    h(DefaultHandler),
    h(DefaultHandler),
    h(DefaultHandler),
    h(DefaultHandler),
    h(DefaultHandler),
    h(DefaultHandler),
    h(DefaultHandler),
    Vector { reserved: 0 },
];
