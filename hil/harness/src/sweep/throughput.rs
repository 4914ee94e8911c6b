//! The campaign's throughput, printed by `hil sweep` and never written into the document:
//! points per core-second, from the CPU time of the threads that ran and collected the
//! points (`/proc/thread-self/schedstat`, ns) and of their children, each point's QEMU
//! (`cutime` + `cstime` of `/proc/self/stat`, 1/100 s). Without those files it is
//! unknown (`None`), not guessed.

use std::time::Duration;

/// What a campaign cost.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Throughput {
    /// Points run.
    pub points: usize,
    /// CPU time of every thread of the campaign, if the OS reports it.
    pub cpu: Option<Duration>,
    /// Wall-clock time of the campaign.
    pub wall: Duration,
}

impl Throughput {
    /// Points per core-second (`points / cpu`), if the CPU time is known and not zero.
    #[must_use]
    pub fn points_per_core_s(&self) -> Option<f64> {
        self.cpu
            .map(|c| c.as_secs_f64())
            .filter(|&s| s > 0.0)
            .map(|s| self.points as f64 / s)
    }
}

impl std::fmt::Display for Throughput {
    /// `100 points in 6.12 s wall, 11.9 core-s of CPU: 8.40 points per core-second`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} points in {:.2} s wall",
            self.points,
            self.wall.as_secs_f64()
        )?;
        match (self.cpu, self.points_per_core_s()) {
            (Some(c), Some(r)) => write!(
                f,
                ", {:.2} core-s of CPU: {r:.2} points per core-second",
                c.as_secs_f64()
            ),
            _ => f.write_str(" (CPU time not reported by this OS)"),
        }
    }
}

/// The calling thread's CPU time so far, if the OS reports it.
#[must_use]
pub fn thread_cpu() -> Option<Duration> {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    let ns = s.split_whitespace().next()?.parse::<u64>().ok()?;
    Some(Duration::from_nanos(ns))
}

/// The CPU time (user + system) of this process's children that have been waited
/// for, if the OS reports it.
#[must_use]
pub fn children_cpu() -> Option<Duration> {
    let s = std::fs::read_to_string("/proc/self/stat").ok()?;
    children_cpu_of(&s)
}

/// `cutime + cstime` of a `/proc/PID/stat` line: fields 16 and 17, in the ABI's fixed
/// 100 ticks per second (after the command in parentheses, which may hold spaces).
fn children_cpu_of(stat: &str) -> Option<Duration> {
    let rest = &stat[stat.rfind(')')? + 1..];
    // `rest` starts at field 3 (the state): fields 16 and 17 are its 14th and 15th.
    let mut f = rest.split_whitespace().skip(13);
    let cutime: u64 = f.next()?.parse().ok()?;
    let cstime: u64 = f.next()?.parse().ok()?;
    Some(Duration::from_millis((cutime + cstime) * 10))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn points_per_core_second() {
        let t = Throughput {
            points: 100,
            cpu: Some(Duration::from_secs(4)),
            wall: Duration::from_secs(2),
        };
        assert_eq!(t.points_per_core_s(), Some(25.0));
        assert!(t.to_string().ends_with("25.00 points per core-second"));
        let unknown = Throughput { cpu: None, ..t };
        assert_eq!(unknown.points_per_core_s(), None);
    }

    #[test]
    fn a_thread_reads_its_cpu_time_where_linux_reports_it() {
        if std::path::Path::new("/proc/thread-self/schedstat").exists() {
            assert!(thread_cpu().is_some());
        }
        if std::path::Path::new("/proc/self/stat").exists() {
            assert!(children_cpu().is_some());
        }
    }

    #[test]
    fn the_children_s_cpu_time_is_cutime_plus_cstime() {
        let line = "42 (hil (x) y) S 1 42 42 0 -1 4194304 100 0 0 0 7 3 250 125 20 0 1 0";
        assert_eq!(children_cpu_of(line), Some(Duration::from_millis(3_750)));
        assert_eq!(children_cpu_of("42 (hil) S 1"), None);
        assert_eq!(children_cpu_of("no parenthesis"), None);
    }
}
