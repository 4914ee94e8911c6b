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

// The firmware's handlers (`device.x` provides `DefaultHandler` for one a build leaves out).
unsafe extern "C" {
    fn UART0RX();
    fn UART0TX();
    fn TIMER0();
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
pub static __INTERRUPTS: [Vector; 32] = {
    const DEFAULT: Vector = h(DefaultHandler);
    let mut v = [DEFAULT; 32];
    v[Interrupt::Uart0Rx as usize] = h(UART0RX);
    v[Interrupt::Uart0Tx as usize] = h(UART0TX);
    v[Interrupt::Timer0 as usize] = h(TIMER0);
    v[Interrupt::Swi0 as usize] = h(SWI0);
    v[Interrupt::Swi1 as usize] = h(SWI1);
    v[31] = Vector { reserved: 0 };
    v
};
