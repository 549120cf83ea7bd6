//! Where a worker process runs: pinned to one CPU, in the batch scheduling
//! class. (Which CPUs there are is `lander_protocol::host::allowed_cpus`.)
//!
//! Pinning and the batch class both matter on small machines. Without pinning, the scheduler places a
//! woken worker near the coordinator that woke it, so at the start of a
//! generation two workers can end up taking turns on one core while the
//! other idles (measured on the 2-core development VM: the second chunk of
//! a generation started only when the first had finished). And a worker in
//! the batch class never preempts the coordinator on waking, so the
//! coordinator finishes handing out a generation before anyone computes.

use std::io;

/// Runs the calling thread, and the threads it starts from now on, on
/// `cpu` only. Call it first thing in `main` to pin the whole process.
pub fn pin_to(cpu: usize) -> io::Result<()> {
    lander_protocol::host::pin_to(cpu).map(|_| ())
}

/// Puts the calling thread, and the threads it starts from now on, in the
/// batch scheduling class: their wake-ups never preempt a running task of
/// the normal class, such as the coordinator.
pub fn run_as_batch_job() -> io::Result<()> {
    let param = libc::sched_param { sched_priority: 0 };
    // SAFETY: sched_setscheduler on this process (pid 0) with a valid param.
    if unsafe { libc::sched_setscheduler(0, libc::SCHED_BATCH, &param) } != 0 {
        return Err(io::Error::last_os_error());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use lander_protocol::host::allowed_cpus;

    #[test]
    fn pinning_to_an_allowed_cpu_sticks_and_a_bad_one_is_refused() {
        // A thread of its own, so the rest of the test process keeps its CPUs.
        std::thread::spawn(|| {
            let first = allowed_cpus()[0];
            pin_to(first).unwrap();
            assert_eq!(allowed_cpus(), [first]);
            assert!(pin_to(libc::CPU_SETSIZE as usize).is_err());
        })
        .join()
        .unwrap();
    }
}
