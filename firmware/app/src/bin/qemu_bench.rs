//! Instruction counts of the control law and the whole runtime tick under QEMU
//! (`-icount shift=10`), for `cargo xtask fw-bench`: one line per measurement, then
//! `FWBENCH law <min> <mean> <max> tick <min> <mean> <max> stack <bytes>`.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
mod bench {
    use cortex_m_semihosting::{debug, hprintln};
    use wheelset_control::{
        Config, Controller, Inputs, Monitor, MonitorEvents, MonitorParams, MonitorState, Outputs,
    };
    use wheelset_fw::app::Stopwatch;
    use wheelset_fw::board::qemu::SysTickStopwatch;
    use wheelset_fw::device::{new_runtime, FwRuntime, Num, DEFAULT_RUNTIME};
    use wheelset_proto::{
        encode_vec, Config as WheelsetConfig, Lateral, Message, RefuseReason, Sensor, YawMode,
    };

    const N: u32 = 2_000;

    /// The control-law step: both loops, limits, safe ramp; per-unit in and out.
    #[inline(never)]
    fn law_step(c: &mut Controller<Num>, i: &Inputs<Num>) -> Outputs<Num> {
        c.tick(i)
    }

    /// Decode one sensor frame, run the tick, encode the actuation frame.
    #[inline(never)]
    fn whole_tick(rt: &mut FwRuntime, frame: &[u8], exec: u32) -> usize {
        rt.receive(frame);
        rt.tick(exec).len()
    }

    /// One base tick of the monitor and actuator check (a step every `div` ticks, 500 Hz).
    #[inline(never)]
    fn monitor_tick(
        m: &Monitor<Num>,
        s: &mut MonitorState<Num>,
        y: Num,
        iref: Num,
    ) -> MonitorEvents {
        m.tick(s, y, true, iref)
    }

    /// Calibration: the same call shape doing nothing.
    #[inline(never)]
    fn nothing(x: u32) -> u32 {
        core::hint::black_box(x)
    }

    #[derive(Clone, Copy)]
    struct Stats {
        min: u32,
        max: u32,
        sum: u64,
        n: u32,
    }

    impl Stats {
        const fn new() -> Self {
            Self {
                min: u32::MAX,
                max: 0,
                sum: 0,
                n: 0,
            }
        }
        fn add(&mut self, x: u32) {
            self.min = self.min.min(x);
            self.max = self.max.max(x);
            self.sum += u64::from(x);
            self.n += 1;
        }
        /// (min, mean, max) with the stopwatch overhead removed.
        fn figures(&self, overhead: u32) -> (u32, u64, u32) {
            let n = u64::from(self.n.max(1));
            (
                self.min.saturating_sub(overhead),
                (self.sum / n).saturating_sub(u64::from(overhead)),
                self.max.saturating_sub(overhead),
            )
        }
        fn print(&self, what: &str, overhead: u32) {
            let (min, mean, max) = self.figures(overhead);
            hprintln!(
                "{} [{}]: min {} mean {} max {} instructions (n = {}, stopwatch overhead {} removed)",
                what,
                wheelset_fw::settings::NUMERIC,
                min,
                mean,
                max,
                self.n,
                overhead
            );
        }
    }

    /// Base rate of the stimulus (Hz): one sample per tick.
    const RATE_HZ: f64 = 5000.0;
    /// The yaw mode's ringing frequency (Hz) and its decay time constant (s).
    const RING_HZ: f64 = 50.0;
    const RING_TAU_S: f64 = 0.2;
    /// Initial y' amplitude (m/s).
    const RING_AMP_M_S: f64 = 0.02;
    /// The vehicle's reference speed in the sensor frame (m/s; the Sensor's `v_ref_mm_s`).
    const V_REF_M_S: f64 = 83.3;

    /// `(cos x, sin x)` for small `|x|` by Taylor series to x^13 (no `sin` in `no_std`).
    const fn cos_sin(x: f64) -> (f64, f64) {
        let (mut c, mut s, mut term, mut k) = (0.0, 0.0, 1.0, 0);
        // term = x^k / k!; even k go to cos, odd to sin, signs alternate in pairs.
        while k <= 13 {
            let sign = if (k / 2) % 2 == 0 { 1.0 } else { -1.0 };
            if k % 2 == 0 {
                c += sign * term;
            } else {
                s += sign * term;
            }
            k += 1;
            term = term * x / k as f64;
        }
        (c, s)
    }

    /// `exp(-x)` for small `x >= 0` (here 0.001) by Taylor series to x^8.
    const fn exp_neg(x: f64) -> f64 {
        let (mut e, mut term, mut k) = (0.0, 1.0, 0);
        while k <= 8 {
            e += term;
            k += 1;
            term = -term * x / k as f64;
        }
        e
    }

    /// The stimulus: `y'(t) = A exp(-t / tau) sin(2 pi f t)` (20 mm/s, 50 Hz, 0.2 s) by a
    /// rotating, decaying phasor; the wheel at 925.6 rad/s with no slip, a demand step at mid-run.
    struct Stimulus {
        k: u32,
        c: f64,
        s: f64,
    }

    impl Stimulus {
        const ROT: (f64, f64) = cos_sin(2.0 * core::f64::consts::PI * RING_HZ / RATE_HZ);
        const DECAY: f64 = exp_neg(1.0 / (RING_TAU_S * RATE_HZ));

        const fn new() -> Self {
            Self {
                k: 0,
                c: RING_AMP_M_S,
                s: 0.0,
            }
        }

        /// `(y' m/s, current A, motor speed rad/s, demand N m)` of the next tick.
        fn next_si(&mut self) -> (f64, f64, f64, f64) {
            let ring = self.s;
            let demand = if self.k > N / 2 { 2460.0 } else { 0.0 };
            let (rc, rs) = Self::ROT;
            let (c, s) = (self.c * rc - self.s * rs, self.s * rc + self.c * rs);
            self.c = c * Self::DECAY;
            self.s = s * Self::DECAY;
            self.k += 1;
            (ring, 100.0 * ring, 925.6, demand)
        }
    }

    /// `N` whole ticks of a fresh default runtime sent `config` first; `None` if refused.
    fn whole_ticks(sw: &mut SysTickStopwatch, config: WheelsetConfig) -> Option<Stats> {
        let mut rt = new_runtime().ok()?;
        let frame = encode_vec(&Message::Config(config)).ok()?;
        rt.receive(&frame);
        if rt.refuse_reason() != RefuseReason::None {
            return None;
        }
        let mut whole = Stats::new();
        let mut exec = 0;
        let mut stim = Stimulus::new();
        for k in 0..N {
            let (y, i, w, d) = stim.next_si();
            let s = Sensor {
                seq: k as u16,
                t_us: (k * 200) as u16,
                lateral: Lateral::Velocity((y * 1e6) as i32),
                i_a_ma: (i * 1e3) as i32,
                omega_m_mrad_s: (w * 1e3) as i32,
                demand_nm: d as i32,
                v_ref_mm_s: (V_REF_M_S * 1e3) as i32,
            };
            let Ok(frame) = encode_vec(&Message::Sensor(s)) else {
                continue;
            };
            let t0 = sw.start();
            core::hint::black_box(whole_tick(&mut rt, &frame, exec));
            exec = sw.stop(t0);
            whole.add(exec);
        }
        Some(whole)
    }

    pub fn run() -> ! {
        wheelset_fw::stack::paint();
        let Some(core) = cortex_m::Peripherals::take() else {
            exit(debug::EXIT_FAILURE)
        };
        let mut sw = SysTickStopwatch::new(core.SYST);

        let mut cal = Stats::new();
        for k in 0..64 {
            let t0 = sw.start();
            core::hint::black_box(nothing(k));
            cal.add(sw.stop(t0));
        }
        let overhead = cal.min;

        let cfg = Config::default();
        let Ok(mut c) = Controller::<Num>::try_new(&cfg) else {
            hprintln!("controller refused the default configuration");
            exit(debug::EXIT_FAILURE)
        };
        // The laws alone: the protection (on by default) off; its cost is the third row's.
        c.set_wsp(false);
        let mut law = Stats::new();
        let mut stim = Stimulus::new();
        for _ in 0..N {
            let (y, i, w, d) = stim.next_si();
            let inp = Inputs::<Num>::from_si(&cfg.scales, y, i, w, d);
            let t0 = sw.start();
            core::hint::black_box(law_step(&mut c, &inp));
            law.add(sw.stop(t0));
        }
        law.print(
            "control-law step (yaw lead + traction PI + limits)",
            overhead,
        );

        let Ok(mon) = Monitor::<Num>::try_new(&MonitorParams::default(), cfg.base_rate_hz) else {
            hprintln!("monitor refused its default configuration");
            exit(debug::EXIT_FAILURE)
        };
        let mut ms = MonitorState::default();
        let (mut mon_all, mut mon_step) = (Stats::new(), Stats::new());
        let mut stim = Stimulus::new();
        for _ in 0..N {
            let (y, i, w, d) = stim.next_si();
            let inp = Inputs::<Num>::from_si(&cfg.scales, y, i, w, d);
            let t0 = sw.start();
            core::hint::black_box(monitor_tick(&mon, &mut ms, inp.y_dot, inp.current));
            let n = sw.stop(t0);
            mon_all.add(n);
            if ms.phase == mon.divisor() {
                mon_step.add(n);
            }
        }
        mon_all.print(
            "monitor, per base tick (stability monitor + actuator check at 500 Hz)",
            overhead,
        );
        mon_step.print("monitor, the ticks that run its step", overhead);

        // The protection switched off, then on (no slip): the rows differ by its check alone.
        let wsp = |on: bool| WheelsetConfig {
            mode: YawMode::Lead,
            traction: true,
            enable: true,
            hold_ticks: DEFAULT_RUNTIME.hold_ticks,
            wsp: on,
            monitor_safe: false,
            rates: None,
        };
        let Some(whole) = whole_ticks(&mut sw, wsp(false)) else {
            hprintln!("runtime refused the default configuration");
            exit(debug::EXIT_FAILURE)
        };
        whole.print(
            "whole tick (decode sensor frame + control + encode actuation frame)",
            overhead,
        );
        let Some(whole_wsp) = whole_ticks(&mut sw, wsp(true)) else {
            hprintln!("runtime refused the default configuration with WSP");
            exit(debug::EXIT_FAILURE)
        };
        whole_wsp.print("whole tick with wheel-slip protection on", overhead);
        let peak = wheelset_fw::stack::peak();
        hprintln!(
            "stack high-water mark [{}]: {} bytes (painted window {} bytes)",
            wheelset_fw::settings::NUMERIC,
            peak,
            wheelset_fw::stack::WINDOW
        );
        let (l, t) = (law.figures(overhead), whole.figures(overhead));
        hprintln!(
            "FWBENCH law {} {} {} tick {} {} {} stack {}",
            l.0,
            l.1,
            l.2,
            t.0,
            t.1,
            t.2,
            peak
        );
        exit(debug::EXIT_SUCCESS)
    }

    fn exit(status: debug::ExitStatus) -> ! {
        loop {
            debug::exit(status);
        }
    }
}

#[cfg(target_os = "none")]
#[cortex_m_rt::entry]
fn main() -> ! {
    bench::run()
}

#[cfg(not(target_os = "none"))]
fn main() {
    println!("wheelset-qemu-bench runs under QEMU: `cargo xtask fw-bench`");
}
