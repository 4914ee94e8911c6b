//! The wheelset's control laws, `no_std`: discretised phase-lead yaw damping and the PI
//! traction current loop, generic over the sample type (`f64` reference, `f32`, and the
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
//! **Delay compensation** of the yaw loop (optional, off by default): the yaw law sees
//! `x = y'[n] + alpha (y'[n] - y'[n-1])`, `alpha = yaw_predict_ticks/yaw_divisor`, a linear
//! extrapolation over the ZOH's half period plus the one tick of transport delay
//! ([`Config::yaw_predict_ticks`] = 1.5 at the default rates). Low-frequency phase
//! `+alpha w T`, gain `1 + O((wT)^2)`; at Nyquist the gain is `1 + 2 alpha` = 4.
//!
//! **Reference ramp** `i_ref[n] = i_ref[n-1] + clamp(target - i_ref[n-1], ±r T)`.
//! **Pure gain** `T_psi = K x`. **Passive** `T_psi = 0`.
//!
//! # Q formats (fixed point, [`FixedController`])
//!
//! Every signal and state is Q4.28 per unit (`i32`, range `[-8, 8)`, LSB `2^-28`), every
//! coefficient Q1.31 validated into `(-1, 1)` (LSB `2^-31`); products are exact 64-bit
//! (`SMLAL` on Cortex-M4), rounded to nearest, and cannot overflow ([`sample::mul_q31`]);
//! sums saturate (`QADD`/`QSUB`). Products round to nearest, so the two recursive
//! states have a small dead band: the lead's low-pass `z` stops within
//! `0.5/kappa` LSB of `g x` (about 10 LSB at 5 kHz: 8 LSB = 0.03 N m at the output)
//! and the PI integrator stops moving once `|Ki e| < 0.5 LSB`, i.e. `|e| < 0.5/Ki`
//! LSB (12 500 LSB = 47 mA at 5 kHz, Ti = 0.5 s). First-order error feedback (carry
//! the product's sub-LSB remainder) removes both at two instructions each; it is not
//! enabled because the audit's instrumented type mirrors [`Fx`] bit for bit and must
//! change with it. Range analysis with
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
//! Chosen from a sampled-data analysis of the loops as they run: the plant discretised
//! exactly with a zero-order hold, **one base period of computation and transport
//! delay** on the actuation (the Actuation frame computed from the Sensor frame of tick
//! `k` is applied at tick `k+1`), these controllers with the f64 coefficients of this
//! crate at their divisors, and the closed-loop (monodromy) eigenvalues over the
//! creep/conicity grid `f11 = f22` in {1, 2, 3, 5, 7, 10} MN x `lambda` in
//! {0.05, 0.1, 0.2, 0.3, 0.4} (`sim-host/src/sampled.rs`; the free-rolling eigenvalue is
//! left out). Numbers below are for the reduced plant (case (c) of the model: rigid axle,
//! no yaw spring, lateral/yaw eqs. 4-5 linearised at 83.3 m/s, plus the armature circuit
//! eq. 9 at constant speed), lead mode, PI `Kp = 1 V/A`, `Ti = 0.5 s`.
//!
//! **Traction current loop.** Continuous crossover `Kp/L_a` = 2500 rad/s (398 Hz); with
//! ZOH and one period of delay its fast closed-loop pair has, per base tick:
//!
//! | base rate | 1 kHz | 2 kHz | 2.5 kHz | 4 kHz | **5 kHz** | 8 kHz | 10 kHz |
//! |---|---|---|---|---|---|---|---|
//! | pole radius | 1.544 | 1.105 | 0.990 | 0.786 | **0.704** | 0.557 | 0.499 |
//! | damping ratio | unstable | unstable | 0.009 | 0.26 | **0.40** | 0.77 | 0.985 |
//!
//! (The test `current_loop_is_unstable_at_2_khz` shows the 2 kHz instability with this
//! controller; `current_loop_settles_at_the_default_rate` the 5 kHz settling.)
//!
//! **Yaw loop (lead).** The continuous lead loop itself is unstable below a creep of
//! 1.33 MN (conicity 0.05) to 1.49 MN (0.4): a high-frequency mode (~13 Hz at 1 MN) the
//! paper's Fig. 4 shows approaching instability. So the 1 MN row of the grid is lost by
//! the control law, not by the rate; over the rest of the grid the question is how much
//! damping sampling costs:
//!
//! | base / yaw divisor | worst sampled zeta where the continuous loop is stable | largest damping loss vs continuous | grid points destabilised by sampling | zeta at 10 MN, 0.2 |
//! |---|---|---|---|---|
//! | 2.5 kHz / 1 | +0.003 (17 Hz, 2 MN, 0.4) | 0.32 (current loop) | 0 | 0.009 |
//! | 4 kHz / 1 | +0.016 | 0.071 | 0 | 0.258 |
//! | **5 kHz / 1** | **+0.020** (17.4 Hz, 2 MN, 0.4) | **0.024** | **0** | **0.310** |
//! | 5 kHz / 2 | +0.014 | 0.032 | 0 | 0.302 |
//! | 5 kHz / 5 (yaw 1 kHz) | -0.003 | 0.056 | 1 | 0.278 |
//! | 10 kHz / 1 | +0.028 | 0.012 | 0 | 0.322 |
//!
//! The least-damped corner (2 MN, conicity 0.4, 17 Hz) is weak in continuous time too;
//! every grid point the continuous loop holds, 5 kHz holds, losing at most 0.024 of
//! damping ratio. Running the yaw loop slower saves nothing that matters (the law costs
//! well under a microsecond; the frames go every base tick anyway) and costs damping,
//! so the yaw divisor is 1; the multi-rate machinery stays for other configurations.
//!
//! **Link budget.** One period must carry the Sensor frame in, the computation and the
//! Actuation frame out (sequential: the reply must be back before the next tick). With
//! the wire format's worst-case frames (33 + 28 bytes, 10 bits per byte) and 10 us of
//! computation, 70 % utilisation needs `610 bits / (0.7 T - 10 us)`: 4.7 Mbaud at 5 kHz,
//! 10.2 Mbaud at 10 kHz. At the 2 Mbaud of a typical USB-serial bridge the largest rate
//! that fits is 2.26 kHz, where the current loop is unstable: **the default needs a
//! link of at least 5 Mbaud** (the STM32F446's USART1/6 on the 90 MHz APB2 reach 11.25 Mbaud with
//! 8x oversampling; e.g. 6 Mbaud = 90 MHz / 15) or, at 2 Mbaud, a lower current-loop
//! gain than the paper's. [`Config::check_link`] refuses a configuration that does not
//! fit. 10 kHz would halve the damping loss but does not fit any realistic UART with
//! these frames.
#![no_std]
#![deny(missing_docs)]

pub mod config;
pub mod controller;
pub mod lead;
pub mod pi;
pub mod sample;

pub use config::{
    Config, ConfigError, FullScales, Limits, Motor, SafeRamps, WireLsb, YawMode,
    DEFAULT_BASE_RATE_HZ, DEFAULT_TRACTION_DIVISOR, DEFAULT_YAW_DIVISOR,
};
pub use controller::{
    Codec, Controller, Counters, F32Controller, F64Controller, FixedController, InputCodes, Inputs,
    OutputCodes, Outputs, SignalCounts,
};
pub use lead::{Lead, LeadDiscrete, LeadParams, LeadPu, LeadState};
pub use pi::{Pi, PiDiscrete, PiFlags, PiParams, PiPu, PiState};
pub use sample::{Coef, Fx, FxScale, Sample};
