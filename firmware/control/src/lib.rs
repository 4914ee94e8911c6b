//! The wheelset's control laws, `no_std`: discretised phase-lead yaw damping, the PI
//! traction current loop and its wheel-slip protection ([`wsp`]), generic over the
//! sample type (`f64` reference, `f32`, and the
//! fixed-point production type [`Fx`] = Q4.28).
//!
//! No allocation, no HAL, no division, no panic on the tick path. Configuration is
//! validated once ([`Controller::try_new`] returns a typed [`ConfigError`]); the tick
//! never fails: it sanitises (NaN -> 0), clamps, and counts ([`Counters`]).
//!
//! ```
//! use wheelset_control::{Config, FixedController, InputCodes};
//! let mut c = FixedController::try_new(&Config::default()).unwrap();
//! // 83.3 m/s: motor speed 925.6 rad/s (codes of 1 mrad/s), y' = 1 mm/s (codes of 1 um/s)
//! let out = c.tick_codes(&InputCodes { y_dot: 1000, current: 0, speed: 925_600, demand: 0 });
//! // Bumpless start: u_a = K_m omega = 4.28 * 925.6 = 3961.6 V (codes of 10 mV).
//! assert!((out.voltage - 396_157).abs() <= 1);
//! // T_psi = +Ks(s) y': the lead's first sample is close to its HF gain 7.875e5 N m s/m.
//! assert!(out.yaw_torque > 0);
//! ```
//!
//! # Signals, units, signs
//!
//! | signal | SI | full scale (1 pu) | clamp / limit (default) | wire LSB (default) |
//! |---|---|---|---|---|
//! | `y'` lateral velocity rel. track, + right | m/s | 1 m/s | ±1 m/s | 1 um/s |
//! | `T_psi` yaw torque | N m | 1e6 N m | ±2e4 N m | 0.1 N m |
//! | `i_a` motor current | A | 1000 A | ±2000 A | 1 mA |
//! | `u_a` motor voltage | V | 1e4 V | [-6000, 6000] V | 10 mV |
//! | `theta_m'` motor speed | rad/s | 1000 rad/s | ±2000 rad/s | 1 mrad/s |
//! | traction demand (wheel torque) | N m | 1e4 N m | ±2e4 N m | 1 N m |
//!
//! Sign of the yaw torque: eq. 5 of the model, `J psi'' + ... = -T_psi`; the active law
//! is `T_psi = +K y'` (or `+Ks(s) y'`): a wheelset moving right is yawed nose-left.
//! Current reference `i_ref = demand/(n K_m)`; back-EMF `K_m theta_m'`.
//!
//! # Discretisation (computed in f64, then quantised)
//!
//! **Lead** `Ks(s) = K a (s + w1)/(s + w2)` by Tustin (optionally pre-warped at `wp`),
//! evaluated as `K_hf (x - z)` with `z` a first-order low-pass of DC gain
//! `g = (w2-w1)/w2` (no nearly-cancelling coefficients; see [`lead`]):
//!
//! ```text
//! c = w2 T/2  (or w2 tan(wp T/2)/wp),  alpha = (1-c)/(1+c),  kappa = 1 - alpha
//! z[n] = z[n-1] + kappa ((g/2)(x[n] + x[n-1]) - z[n-1])
//! y[n] = K_hf (x[n] - z[n]),   K_hf = K a
//! ```
//!
//! DC gain `K_hf (1 - g) = K a w1/w2` = 1.05e5 x 7.5 x 37/274 = 1.0634e5 N m s/m,
//! independent of `kappa`'s quantisation.
//!
//! **PI** `Kp (1 + 1/(Ti s))`, backward-Euler integrator (`1/s -> T/(1 - z^-1)`), with
//! the integrator clamped to the output limits (anti-windup by clamping; see [`pi`]):
//!
//! ```text
//! e = i_ref - i_a,  I[n] = clamp(I[n-1] + (Kp T/Ti) e[n]),  u[n] = clamp(Kp e[n] + I[n])
//! ```
//!
//! **Delay compensation** of the yaw loop (on by default, 1.5 ticks; 0 turns it off): the yaw law sees
//! `x = y'[n] + alpha (y'[n] - y'[n-1])`, `alpha = yaw_predict_ticks/yaw_divisor`, a linear
//! extrapolation over the ZOH's half period plus the one tick of transport delay
//! ([`Config::yaw_predict_ticks`] = 1.5 at the default rates). Low-frequency phase
//! `+alpha w T`, gain `1 + O((wT)^2)`; at Nyquist the gain is `1 + 2 alpha` = 4.
//!
//! **Reference ramp** `i_ref[n] = i_ref[n-1] + clamp(target - i_ref[n-1], ±r T)`.
//! **Pure gain** `T_psi = K x`. **Passive** `T_psi = 0`.
//!
//! # No float functions on the device
//!
//! The tick is additions, multiplications, shifts and comparisons in every sample type:
//! no `sqrt`, `exp`, `tan` or other `libm` function runs on the device, in the fixed-point
//! build or the `f32` one (neither ELF links one). The transcendental functions of the
//! discretisation (`e^{-pT}`, the bilinear map's `tan`, the monitor's decay) run once, in
//! f64, where a configuration is compiled: on the host and in the firmware's build script,
//! which hand the device exact bits ([`Compiled::from_bits`]; a rate switch's
//! coefficients are computed on the host too). They are series in this crate
//! ([`lead`]'s `tan`, [`monitor`]'s `exp`) rather than `libm` so that the compiled
//! coefficients are the same bits on every host and in the build script. `micromath`'s
//! `f32` approximations therefore have no call site: the device needs no float function,
//! and the one place that does needs f64 and reproducible bits, which an `f32`
//! approximation is not.
//!
//! # Q formats (fixed point, [`FixedController`])
//!
//! Every signal and state is Q4.28 per unit (`i32`, range `[-8, 8)`, LSB `2^-28`), every
//! coefficient Q1.31 validated into `(-1, 1)` (LSB `2^-31`); products are exact 64-bit
//! (`SMLAL` on Cortex-M4), rounded to nearest, and cannot overflow ([`sample::mul_q31`]);
//! sums saturate (`QADD`/`QSUB`). Products round to nearest, so the lead's low-pass
//! `z` has a small dead band: it stops within `0.5/kappa` LSB of `g x` (about 10 LSB at
//! 5 kHz: 8 LSB = 0.03 N m at the output). The PI integrator's increment `Ki e` instead
//! uses first-order error feedback ([`Sample::mul_c_acc`]: floor, carry the sub-LSB
//! remainder to the next step): with round-to-nearest it stopped moving for
//! `|e| < 0.5/Ki` LSB (47 mA at 5 kHz, Ti = 0.5 s) and summed a rounding bias to 0.18 V
//! over a 20 s open-loop replay (`hil audit` failed on it); with the carry the running
//! sum is exact to one LSB. Range analysis with
//! the inputs clamped to `|x| <= X` pu, `X <= 2` (enforced by [`Config::validate`]):
//!
//! | signal / state | bound | why |
//! |---|---|---|
//! | `y'` | `X` (1) | clamped, counted |
//! | `(y'[n] - y'[n-1]) alpha/2` | `alpha X` (1.5) | predictor, `alpha = 1.5 < 2` |
//! | `x = y' + alpha (y'[n] - y'[n-1])` | 2 | clamped to 2 pu, counted with `y'` |
//! | `x[n] + x[n-1]` | 4 | |
//! | lead `z` | `2 g` (1.73) | Tustin low-pass with `alpha > 0` has a positive impulse response summing to `g` (`alpha > 0` is enforced: `w2 T/2 < 1`) |
//! | `x - z` | `2 (1+g)` (3.73) | |
//! | `T_psi` before limit | `2 K_hf (1+g)` = 2.94 pu | K_hf = 0.7875 pu |
//! | `i_a`, `i_ref`, `e = i_ref - i_a` | 2, 2, 4 pu | clamps, `demand_max/(n K_m)` validated <= 2 pu |
//! | PI `Kp e` | 0.4 pu | Kp = 0.1 pu |
//! | PI `I`, `u` | 0.6 pu | clamped to the voltage limits |
//! | back-EMF `K_m w` | 0.86 pu | `K_m` = 0.428 pu, `w` clamped to 2 pu |
//!
//! So no internal saturation can engage (a full-scale test checks it); the largest
//! value is 4 pu of the 8 available. Resolution: y' 3.7e-9 m/s, T_psi 3.7e-3 N m,
//! i_a 3.7e-6 A, u_a 3.7e-5 V: far below the wire LSBs. Coefficient quantisation
//! (Q1.31, relative error <= 2^-32/|c|): `K_hf` 3e-10, `g/2` 5e-10, `kappa` (5 kHz)
//! 9e-9, PI `Ki` (5 kHz, Ti = 0.5 s) 5.8e-6 relative.
//!
//! # Rates (default: base 5 kHz, yaw and traction both every tick)
//!
//! Chosen from a sampled-data analysis of the loops as they run (`sim-host rates`,
//! `sim-host/plant/src/sampled.rs`): the plant linearised at pure rolling on straight track,
//! discretised exactly with a zero-order hold (matrix exponential), **one base period
//! of computation and transport delay** on the actuation (the Actuation frame computed
//! from the Sensor frame of tick `k` is applied at tick `k+1`), these controllers with
//! the f64 coefficients of this crate at their divisors (a test checks that the
//! matrices reproduce [`F64Controller`] tick for tick), and the eigenvalues of the
//! closed loop over one hyper-period, over the grid `f11 = f22` in
//! {1, 2, 3, 5, 7, 10} MN x conicity {0.05, 0.1, 0.2, 0.3, 0.4}. The free-rolling
//! eigenvalue is left out. Plant: case (d), the flexible axle (40 Hz), the motor on its
//! gear spring, the armature circuit; lead mode; PI `Kp = 1 V/A`, `Ti = 0.5 s`.
//!
//! **Traction current loop.** Continuous crossover `Kp/L_a` = 2500 rad/s (398 Hz); with
//! ZOH and one period of delay its fast closed-loop pair has, per base tick:
//!
//! | base rate | 1 kHz | 2 kHz | 2.5 kHz | 4 kHz | **5 kHz** | 8 kHz | 10 kHz |
//! |---|---|---|---|---|---|---|---|
//! | pole radius | 1.544 | 1.105 | 0.990 | 0.786 | **0.704** | 0.557 | 0.499 |
//! | damping ratio | unstable | unstable | 0.009 | 0.26 | **0.40** | 0.77 | 0.985 |
//!
//! (`current_loop_is_unstable_at_2_khz` and `current_loop_settles_at_the_default_rate`
//! show both with this controller.) So with the paper's gains the base rate must be
//! 5 kHz or more; at a slower rate the device runs gains designed for it ([`design`]).
//!
//! **Yaw loop (lead).** In continuous time the paper's lead loop is already unstable
//! below a creep of about 1.55 MN (1.54 MN at conicity 0.05, 1.57 MN at 0.2: the
//! high-frequency mode, ~13-16 Hz there, that the paper's Fig. 4 shows approaching
//! instability), and only lightly damped at 2-3 MN (zeta 0.006-0.015, 19-22 Hz). So
//! the 1 MN row is lost by the control law at any rate; the rate decides how much of
//! the rest survives. Without compensation, sampling costs damping in proportion to the
//! delay (about 1.5 T x 360 deg x f of phase): zeta loss 0.024 at 5 kHz, 0.012 at
//! 10 kHz, and the 2-3 MN rows (10 grid points) go unstable at every rate up to 10 kHz
//! (they would need about 20 kHz). With the yaw delay compensation
//! ([`Config::yaw_predict_ticks`] = 1.5: `y'` extrapolated over the ZOH's half period
//! plus the one tick of delay), the sampled loop keeps the continuous loop's damping:
//!
//! | base / yaw divisor | compensation | worst zeta where the continuous loop is stable | largest zeta loss | grid points destabilised by sampling | zeta at 10 MN, 0.2 |
//! |---|---|---|---|---|---|
//! | 5 kHz / 1 | off | -0.009 (18.7 Hz, 2 MN) | 0.024 | 10 | 0.046 |
//! | 10 kHz / 1 | off | -0.002 | 0.012 | 5 | 0.054 |
//! | 4 kHz / 1 | on | +0.005 (18.8 Hz, 2 MN) | 0.0017 | 0 | 0.061 |
//! | **5 kHz / 1** | **on** | **+0.005** (continuous: +0.006) | **0.0011** | **0** | **0.062** |
//! | 5 kHz / 5 (yaw 1 kHz) | on | +0.004 | 0.0097 | 0 | 0.053 |
//! | 5 kHz / 10 (yaw 500 Hz) | on | -0.002 | 0.035 | 5 | 0.028 |
//!
//! The yaw divisor is 1: running the yaw loop slower saves nothing that matters (the
//! law costs well under a microsecond; the frames go every base tick anyway) and costs
//! damping. The compensation is **on by default** (1.5 ticks at these rates): without it
//! sampling alone destabilises 10 grid points that the continuous law keeps stable;
//! `yaw_predict_ticks = 0` gives the paper's law unmodified.
//!
//! **Link budget.** One period must carry the Sensor frame in, the computation and the
//! Actuation frame out (sequential: the reply must be back before the next tick):
//! `(up + down) bytes x 10 bits / baud + 2 latency` within a share of the period, with
//! the wire format's worst-case frames (`wheelset_proto::sizes`). The one link budget,
//! `wheelset_proto::link::link_fits` (integer, `const fn`: the rate table at 70 %, the
//! device loop and hil at 85 % of the period), refuses a configuration that does not
//! fit; `sim-host rates` prints the baud each candidate rate needs. The default 5 kHz
//! needs more than 4 Mbaud (`wheelset-loop`'s `tests/sim_link.rs`): more than a typical
//! USB-serial bridge carries, within what the Nucleo build's USART2 makes (on APB1 at
//! 42 MHz with 8x oversampling and USARTDIV 1, `wheelset-fw`'s `board::stm32::clock`).
//! On a slower link the rate that fits is one where the current loop at the paper's
//! gain is unstable: the gains designed for that rate and delay ([`design`]: a lower
//! `Kp`, the yaw law's margins kept) are what a device runs there.
//!
//! Selection rule of `sim-host rates`: the lowest base rate whose current loop has
//! radius <= 0.75 per tick, with no grid point destabilised by sampling and a link
//! within 6 Mbaud, ties broken by the smaller damping loss: 5 kHz / 1 / 1 (with the
//! compensation; without it no candidate up to 10 kHz qualifies, and 5 kHz is the
//! fastest that the link allows).
//!
//! # Measured
//!
//! Fixed point (Q4.28) against the f64 reference on the same quantised inputs, 1 s at
//! 5 kHz (`cargo test -p wheelset-control --test numerics -- --nocapture`):
//!
//! | input | `T_psi` max / RMS error | `u_a` max / RMS error |
//! |---|---|---|
//! | steps (y' 1 mm/s .. 1 m/s, current step) | 7.3 / 7.1 LSB (0.027 N m) | 14 / 11 LSB (0.0005 V) |
//! | chirp 0.1 Hz .. fs/2 | 2.1 / 0.19 LSB (0.008 N m) | 26 / 15 LSB (0.001 V) |
//! | full scale, alternating rails | 0.12 / 0.12 LSB | 198 / 107 LSB (0.007 V) |
//!
//! (1 LSB = `2^-28` pu: 3.7e-3 N m of torque, 3.7e-5 V of voltage.) The torque error is
//! the lead's dead band; the voltage error is the PI's output rounding plus at most one
//! LSB of carried integrator remainder. Asserted bounds: 16 LSB of torque, `4 + 0.75 N`
//! LSB of voltage after `N` traction steps, over random, step, chirp and full-scale
//! property tests.
//!
//! One tick, host: `cargo bench -p wheelset-control`. On the Cortex-M4 (QEMU `mps2-an386`, instructions
//! executed, `cargo xtask fw-bench`, profile `fw`, which prints the figures): a whole
//! controller tick (both loops, the y' predictor, input clamps, reference ramp,
//! safe-state logic, counters) runs the fast path of [`Controller::tick`] in normal
//! running: each loop straight through, each clamp a single unsigned compare that it
//! would not engage (the torque limit applied inline), the reference ramp skipped while
//! settled, products in one `SMMULR` where the ranges allow it ([`Sample::mul_pre`],
//! [`Sample::mul_c_small`]); anything else (a clamp, NaN, the safe state, a law change,
//! traction off) takes the general path, which the fast path equals bit for bit
//! (`tests/fast_path.rs`). What remains is the arithmetic itself: the products and
//! saturating adds of the two laws, the loads of coefficients and states and the stores
//! of the states, the range checks, the counters, the call and the mode check.
#![no_std]
#![deny(missing_docs)]

pub mod compiled;
pub mod config;
pub mod controller;
pub mod design;
pub mod lead;
pub mod monitor;
pub mod pi;
pub mod sample;
pub mod wsp;

pub use compiled::{BitsError, Compiled, CompiledBits, ScaleBits, ScheduleBits};
pub use config::{
    Config, ConfigError, FullScales, Limits, Motor, SafeRamps, WireLsb, YawMode,
    DEFAULT_BASE_RATE_HZ, DEFAULT_TRACTION_DIVISOR, DEFAULT_YAW_DIVISOR,
};
pub use controller::{
    Codec, Controller, Counters, F32Controller, F64Controller, FixedController, InputCodes, Inputs,
    OutputCodes, Outputs, SignalCounts, TickEvents,
};
pub use lead::{Lead, LeadDiscrete, LeadParams, LeadPu, LeadState};
pub use monitor::{Monitor, MonitorBits, MonitorEvents, MonitorParams, MonitorState, QUIET_BLOCKS};
pub use pi::{Pi, PiDiscrete, PiFlags, PiParams, PiPu, PiState};
pub use sample::{Coef, Fx, FxScale, Sample, SampleBits};
pub use wsp::{Wsp, WspBits, WspParams, WspState};
