//! The synthetic input scenarios ([`synthetic`]); the closed-loop ones: [`super::recordings`].

use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use wheelset_control::Config;

use super::ranges::{Event, Scenario, Tick};

/// The synthetic scenarios: full-scale steps (every input to and beyond its clamp,
/// Nyquist alternation, safe-state and traction toggles), a chirp to `0.45 fs`, and
/// uniform random full-scale inputs. `speed` for the bumpless preset at the limit.
pub fn synthetic(cfg: &Config) -> Vec<Scenario> {
    let fs = cfg.base_rate_hz as f64;
    let l = cfg.limits;
    let n = |s: f64| (s * fs).round() as usize;
    let mut t = Vec::new();
    let levels = [1.0, -1.0, 1.5, -1.5, 0.0, 1.0, -1.0, 0.0];
    for (k, lv) in levels.iter().enumerate() {
        for j in 0..n(0.2) {
            // The safe state entered at the fifth level, left at the sixth.
            let event = (j == 0 && (k == 4 || k == 5)).then_some(Event::Safe(k == 4));
            t.push(Tick {
                si: [lv * l.y_dot, -lv * l.current, l.speed, lv * l.demand],
                event,
            });
        }
    }
    // Nyquist alternation at full scale, then traction off/on with the speed at its limit.
    for j in 0..n(0.05) {
        let s = if j % 2 == 0 { 1.0 } else { -1.0 };
        t.push(Tick {
            si: [s * l.y_dot, s * l.current, -l.speed, -s * l.demand],
            event: None,
        });
    }
    t.push(Tick {
        si: [0.0, 0.0, -l.speed, 0.0],
        event: Some(Event::Traction(false)),
    });
    for j in 0..n(0.3) {
        t.push(Tick {
            si: [0.0, l.current, -l.speed, -l.demand],
            event: (j == 0).then_some(Event::Traction(true)),
        });
    }
    let steps = Scenario {
        unstable: None,
        name: "full_scale_steps".into(),
        source: "synthetic: every input stepped to +-1 and +-1.5 x its clamp, Nyquist \
                 alternation, safe state and traction toggles"
            .into(),
        ticks: t,
    };
    // Chirp 0.1 Hz .. 0.45 fs (exponential), 10 mm/s and 50 A around the paper's point.
    let dur = 4.0;
    let (f0, f1) = (0.1, 0.45 * fs);
    let m = n(dur);
    let k = (f1 / f0).ln() / dur;
    let mut ticks = Vec::with_capacity(m);
    for i in 0..m {
        let tt = i as f64 / fs;
        let ph = 2.0 * std::f64::consts::PI * f0 * ((k * tt).exp() - 1.0) / k;
        ticks.push(Tick {
            si: [0.01 * ph.sin(), 115.0 + 50.0 * ph.sin(), 925.6, 2460.0],
            event: None,
        });
    }
    let chirp = Scenario {
        unstable: None,
        name: "chirp".into(),
        source: format!(
            "synthetic: exponential chirp {f0} Hz .. {f1:.0} Hz over {dur} s, y' 10 mm/s, \
             i_a 115 +- 50 A, demand 2460 N m"
        ),
        ticks,
    };
    let mut g = Pcg64::seed_from_u64(0x5eed_a0d1);
    let mut uniform = |a: f64| a * g.random_range(-1.0..1.0);
    let ticks = (0..n(1.0))
        .map(|_| Tick {
            si: [
                uniform(1.2 * l.y_dot),
                uniform(1.2 * l.current),
                uniform(l.speed),
                uniform(1.2 * l.demand),
            ],
            event: None,
        })
        .collect();
    let random = Scenario {
        unstable: None,
        name: "random_full_scale".into(),
        source: "synthetic: uniform random inputs over 1.2 x each clamp, 1 s".into(),
        ticks,
    };
    vec![steps, chirp, random]
}
