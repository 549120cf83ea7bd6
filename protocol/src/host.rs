//! What both sides of a run read of the host they run on: the CPUs this
//! process may use, from which the coordinator places its workers, and
//! pinning a thread to one of them; the
//! host's monotonic clock, in which workers stamp their results and the
//! pool its requests and answers; a thread's CPU time, which `lander
//! bench` reports; and this process's memory and open descriptors, which
//! a soak watches; and its name, which a worker tells its coordinator.

use std::time::Duration;

/// This host's name, as the kernel has it; `unknown` if it cannot be read.
pub fn name() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .map(|s| s.trim().to_string())
        .ok()
        .filter(|s| !s.is_empty())
        .unwrap_or_else(|| "unknown".into())
}

/// The CPUs this process may run on, in order; empty if unknown.
pub fn allowed_cpus() -> Vec<usize> {
    // SAFETY: a zeroed cpu_set_t is a valid empty set; sched_getaffinity
    // writes at most size_of::<cpu_set_t>() bytes into it.
    unsafe {
        let mut set: libc::cpu_set_t = std::mem::zeroed();
        if libc::sched_getaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &mut set) != 0 {
            return Vec::new();
        }
        (0..libc::CPU_SETSIZE as usize)
            .filter(|&cpu| libc::CPU_ISSET(cpu, &set))
            .collect()
    }
}

/// The CPUs a thread ran on before [`pin_to`] pinned it.
#[derive(Clone, Copy)]
pub struct Affinity(libc::cpu_set_t);

/// The calling thread pinned to one CPU until this is dropped, when it may
/// run where it ran before. Not `Send`: it must be dropped on the thread
/// it pinned.
pub struct Pinned {
    before: Affinity,
    _on_this_thread: std::marker::PhantomData<*const ()>,
}

impl Pinned {
    /// Pins the calling thread to `cpu` (see [`pin_to`]) until dropped.
    pub fn here(cpu: usize) -> std::io::Result<Pinned> {
        Ok(Pinned {
            before: pin_to(cpu)?,
            _on_this_thread: std::marker::PhantomData,
        })
    }
}

impl Drop for Pinned {
    fn drop(&mut self) {
        // Nothing to do about a failure: the thread stays where it was.
        let _ = self.before.restore();
    }
}

impl Affinity {
    /// Lets the calling thread run on these CPUs again.
    pub fn restore(&self) -> std::io::Result<()> {
        // SAFETY: a cpu_set_t read by sched_getaffinity, of its own size.
        if unsafe { libc::sched_setaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &self.0) }
            != 0
        {
            return Err(std::io::Error::last_os_error());
        }
        Ok(())
    }
}

/// Runs the calling thread, and the threads it starts from now on, on
/// `cpu` only; returns the CPUs it could run on before.
pub fn pin_to(cpu: usize) -> std::io::Result<Affinity> {
    if cpu >= libc::CPU_SETSIZE as usize {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            format!("CPU {cpu} is beyond the largest CPU number this system supports"),
        ));
    }
    // SAFETY: zeroed cpu_set_t values are valid empty sets; `cpu` is below
    // CPU_SETSIZE, so CPU_SET stays inside the set; both calls are given
    // the set's own size.
    unsafe {
        let mut before: libc::cpu_set_t = std::mem::zeroed();
        if libc::sched_getaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &mut before) != 0 {
            return Err(std::io::Error::last_os_error());
        }
        let mut set: libc::cpu_set_t = std::mem::zeroed();
        libc::CPU_SET(cpu, &mut set);
        if libc::sched_setaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &set) != 0 {
            return Err(std::io::Error::last_os_error());
        }
        Ok(Affinity(before))
    }
}

/// CPU time the calling thread has used so far; zero if the clock cannot
/// be read. Exact to the call, unlike /proc's schedstat, which lags for a
/// running thread.
pub fn thread_cpu_time() -> Duration {
    cpu_clock(libc::CLOCK_THREAD_CPUTIME_ID)
}

/// CPU time every thread of this process has used so far (a transport's
/// I/O threads as well as the caller); zero if the clock cannot be read.
pub fn process_cpu_time() -> Duration {
    cpu_clock(libc::CLOCK_PROCESS_CPUTIME_ID)
}

fn cpu_clock(clock: libc::clockid_t) -> Duration {
    let mut t = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime writes one timespec into `t`.
    if unsafe { libc::clock_gettime(clock, &mut t) } != 0 {
        return Duration::ZERO;
    }
    Duration::new(t.tv_sec as u64, t.tv_nsec as u32)
}

/// This process's resident memory in KiB, from /proc; `None` if unknown.
pub fn resident_kib() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmRSS:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

/// The file descriptors this process has open, from /proc; `None` if
/// unknown.
pub fn open_descriptors() -> Option<usize> {
    Some(std::fs::read_dir("/proc/self/fd").ok()?.count())
}

/// The host's monotonic clock in nanoseconds: one clock for every process
/// on the host, unlike [`std::time::Instant`], which cannot be sent to
/// another process. Zero if the clock cannot be read.
pub fn host_clock_ns() -> u64 {
    let mut t = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime writes one timespec into `t`.
    if unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut t) } != 0 {
        return 0;
    }
    t.tv_sec as u64 * 1_000_000_000 + t.tv_nsec as u64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_thread_pinned_to_one_cpu_runs_there_until_restored() {
        // A thread of its own, so the rest of the test process keeps its CPUs.
        std::thread::spawn(|| {
            let before = allowed_cpus();
            let last = *before.last().unwrap();
            let affinity = pin_to(last).unwrap();
            assert_eq!(allowed_cpus(), [last]);
            // A thread started now runs there too.
            let child = std::thread::spawn(allowed_cpus).join().unwrap();
            assert_eq!(child, [last]);
            affinity.restore().unwrap();
            assert_eq!(allowed_cpus(), before);
            {
                let _pinned = Pinned::here(last).unwrap();
                assert_eq!(allowed_cpus(), [last]);
            }
            assert_eq!(allowed_cpus(), before, "the guard restores on drop");
            assert!(pin_to(libc::CPU_SETSIZE as usize).is_err());
        })
        .join()
        .unwrap();
    }

    #[test]
    fn a_busy_thread_uses_cpu_time_and_a_sleeping_one_does_not() {
        let start = thread_cpu_time();
        let mut x = 0u64;
        while thread_cpu_time() - start < Duration::from_millis(5) {
            x = std::hint::black_box(x.wrapping_add(1));
        }
        let busy = thread_cpu_time();
        assert!(busy - start >= Duration::from_millis(5));
        std::thread::sleep(Duration::from_millis(50));
        assert!(thread_cpu_time() - busy < Duration::from_millis(20));
    }

    #[test]
    fn the_host_clock_moves_with_instant() {
        // Each `Instant` between two reads of the host clock, so that a
        // preemption between the reads widens the bounds rather than
        // failing the test.
        let bracket = || {
            let before = host_clock_ns();
            let instant = std::time::Instant::now();
            (before, instant, host_clock_ns())
        };
        let (a_before, a, a_after) = bracket();
        std::thread::sleep(Duration::from_millis(20));
        let (b_before, b, b_after) = bracket();
        let elapsed = b - a;
        let least = Duration::from_nanos(b_before - a_after);
        let most = Duration::from_nanos(b_after - a_before);
        assert!(most >= Duration::from_millis(20), "{most:?}");
        // A microsecond either way for the clocks' own resolution.
        let slack = Duration::from_micros(1);
        assert!(
            elapsed + slack >= least && elapsed <= most + slack,
            "{elapsed:?} outside {least:?}..{most:?}"
        );
    }

    #[test]
    fn this_process_may_run_somewhere() {
        let cpus = allowed_cpus();
        assert!(!cpus.is_empty());
        assert!(cpus.windows(2).all(|w| w[0] < w[1]), "{cpus:?}");
    }
}
