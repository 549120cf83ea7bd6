//! Worker processes the coordinator starts itself: placed ([`Placement`]:
//! each pinned to a CPU of its own when there are enough, and told to spin
//! where no other process of the run needs its CPU), spawned, reaped with
//! `waitpid` (iceoryx2 cannot tell a zombie from a live process) and
//! replaced a bounded number of times, a replacement taking its
//! predecessor's CPU.

use crate::evaluator::EvalError;
use std::os::fd::{AsRawFd, FromRawFd, OwnedFd};
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// Where a pool's spawned workers run, where the coordinator's own thread
/// runs, and which workers may spin before they sleep.
///
/// With fewer workers than CPUs, every worker and the coordinator have a
/// CPU of their own: the workers are pinned one to a CPU and all of them
/// spin. With as many workers as CPUs, the coordinator's thread is pinned
/// beside the last worker, which does not spin; every other worker still
/// has a CPU of its own, and spins. With more workers than CPUs, or
/// without pinning, nobody is pinned and nobody spins (unless the workers
/// are fewer than the CPUs).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Placement {
    /// Each worker's CPU, in the order they are spawned; empty: unpinned.
    pub cpus: Vec<usize>,
    /// The CPU the coordinator's thread shares with the last worker.
    pub coordinator: Option<usize>,
    /// Every worker has a CPU of its own.
    spin_all: bool,
    /// How long a worker with a CPU of its own polls, in µs.
    spin_us: Option<u128>,
}

impl Placement {
    /// `workers` spawned on the `allowed` CPUs, pinned if `pin`, those
    /// with a CPU of their own polling for `spin` before they sleep.
    pub fn new(workers: usize, allowed: &[usize], pin: bool, spin: Duration) -> Placement {
        let pinned = pin && workers > 0 && workers <= allowed.len();
        let cpus = if pinned {
            allowed[..workers].to_vec()
        } else {
            Vec::new()
        };
        Placement {
            coordinator: (pinned && workers == allowed.len()).then(|| allowed[workers - 1]),
            cpus,
            spin_all: cpu_to_spare(workers, allowed.len()),
            spin_us: (!spin.is_zero()).then_some(spin.as_micros()),
        }
    }

    /// The spin budget of a worker pinned to `cpu` (`None`: unpinned), if
    /// it may spin at all.
    pub fn spin_us(&self, cpu: Option<usize>) -> Option<u128> {
        let own = self.spin_all || (cpu.is_some() && cpu != self.coordinator);
        self.spin_us.filter(|_| own)
    }
}

/// Whether `workers` spawned workers on `cpus` CPUs leave one for the
/// coordinator: the rule by which every worker spins and, by default, the
/// coordinator flies a share (`--coordinator-share auto`).
pub fn cpu_to_spare(workers: usize, cpus: usize) -> bool {
    workers < cpus
}

pub struct Children {
    exe: PathBuf,
    run_id: String,
    /// What the transport needs on the worker's command line.
    args: Vec<String>,
    placement: Placement,
    /// Each live worker.
    procs: Vec<Spawned>,
    /// CPUs no live worker is pinned to, handed out next.
    free_cpus: Vec<usize>,
    next_id: u64,
    respawns_left: usize,
}

/// A worker started here: its process, the id it was given, and the CPU
/// it is pinned to, if any.
struct Spawned {
    child: Child,
    id: u64,
    cpu: Option<usize>,
    started: Instant,
}

impl Spawned {
    fn child_id(&self) -> ChildId {
        ChildId {
            id: self.id,
            pid: self.child.id(),
        }
    }

    fn is(&self, worker: ChildId) -> bool {
        self.child_id() == worker
    }
}

/// A worker started here: the id it was given, which it announces when
/// it joins, and its pid. Both name it: a worker of another host may have
/// the same pid, and one started by hand the same id.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ChildId {
    pub id: u64,
    pub pid: u32,
}

impl ChildId {
    /// What names the worker behind `link`, if it is one started here.
    pub fn of(link: &impl super::WorkerLink) -> ChildId {
        ChildId {
            id: link.id(),
            pid: link.pid(),
        }
    }
}

impl Children {
    /// Workers of `exe` for run `run_id`, placed as `placement` says.
    pub fn new(
        exe: PathBuf,
        run_id: String,
        args: Vec<String>,
        max_respawns: usize,
        placement: Placement,
    ) -> Children {
        let mut free_cpus = placement.cpus.clone();
        free_cpus.reverse();
        Children {
            exe,
            run_id,
            args,
            placement,
            procs: Vec::new(),
            free_cpus,
            next_id: 1,
            respawns_left: max_respawns,
        }
    }

    pub fn is_empty(&self) -> bool {
        self.procs.is_empty()
    }

    /// True if `worker` is a live worker started here.
    pub fn started(&self, worker: ChildId) -> bool {
        self.procs.iter().any(|p| p.is(worker))
    }

    /// True if `worker` is a live worker started here on the CPU that the
    /// coordinator's thread shares with it ([`Placement::coordinator`]).
    pub fn beside_coordinator(&self, worker: ChildId) -> bool {
        self.beside() == Some(worker)
    }

    /// The live worker started here on the CPU that the coordinator's
    /// thread shares with it, if there is one.
    pub fn beside(&self) -> Option<ChildId> {
        let cpu = self.placement.coordinator?;
        self.procs
            .iter()
            .find(|p| p.cpu == Some(cpu))
            .map(Spawned::child_id)
    }

    /// Whether a live worker started here runs elsewhere than on the CPU
    /// the coordinator's thread shares ([`Children::beside`]).
    pub fn any_apart(&self) -> bool {
        let beside = self.beside();
        self.procs.iter().any(|p| Some(p.child_id()) != beside)
    }

    /// Starts one more worker, on the next free CPU if any.
    pub fn spawn(&mut self) -> Result<ChildId, EvalError> {
        let cpu = self.free_cpus.pop();
        let mut command = Command::new(&self.exe);
        command.args([
            "--run",
            &self.run_id,
            "--id",
            &format!("{:x}", self.next_id),
            "--quiet",
            "--parent",
            &std::process::id().to_string(),
        ]);
        if let Some(cpu) = cpu {
            command.args(["--cpu", &cpu.to_string()]);
        }
        if let Some(us) = self.placement.spin_us(cpu) {
            command.args(["--spin-us", &us.to_string()]);
        }
        let child = command
            .args(&self.args)
            .stdin(Stdio::null())
            .spawn()
            .map_err(|e| {
                self.free_cpus.extend(cpu);
                EvalError::Spawn {
                    exe: self.exe.display().to_string(),
                    reason: e.to_string(),
                }
            })?;
        let spawned = Spawned {
            child,
            id: self.next_id,
            cpu,
            started: Instant::now(),
        };
        let started = spawned.child_id();
        self.procs.push(spawned);
        self.next_id += 1;
        Ok(started)
    }

    /// Replaces a worker that died, while the respawn budget lasts.
    /// Returns the new worker, or `None` once the budget is spent.
    pub fn respawn(&mut self) -> Result<Option<ChildId>, EvalError> {
        if self.respawns_left == 0 {
            return Ok(None);
        }
        self.respawns_left -= 1;
        self.spawn().map(Some)
    }

    /// Reaps the workers that exited and returns them.
    pub fn exited(&mut self) -> Vec<ChildId> {
        let mut gone = Vec::new();
        self.procs.retain_mut(|p| match p.child.try_wait() {
            Ok(None) => true,
            Ok(Some(_)) | Err(_) => {
                gone.push(p.child_id());
                self.free_cpus.extend(p.cpu);
                false
            }
        });
        gone
    }

    /// Waits at most `grace` for the spawned workers among `pids` to exit;
    /// the next `exited` reaps those that did. Pids not spawned here are
    /// not waited for.
    pub fn await_exit(&mut self, pids: &[u32], grace: Duration) {
        let until = Instant::now() + grace;
        loop {
            // `try_wait` keeps a status it found, for `exited` to see.
            let running: Vec<u32> = self
                .procs
                .iter_mut()
                .filter(|p| pids.contains(&p.child.id()))
                .filter_map(|p| matches!(p.child.try_wait(), Ok(None)).then(|| p.child.id()))
                .collect();
            if running.is_empty() || Instant::now() >= until {
                return;
            }
            sleep_until_one_exits(&running, until);
        }
    }

    /// The workers started more than `within` ago that `joined` does not
    /// know: started, but never heard from.
    pub fn not_joined<'a>(
        &'a self,
        joined: impl Fn(ChildId) -> bool + 'a,
        within: Duration,
    ) -> impl Iterator<Item = ChildId> + 'a {
        self.procs
            .iter()
            .map(|p| (p.child_id(), p.started))
            .filter(move |&(c, started)| !joined(c) && started.elapsed() > within)
            .map(|(c, _)| c)
    }

    /// Kills a hung worker started here; the next `exited` reaps it.
    pub fn kill(&mut self, worker: ChildId) {
        if let Some(p) = self.procs.iter_mut().find(|p| p.is(worker)) {
            let _ = p.child.kill();
        }
    }

    /// Kills every worker, for a pool that cannot use them.
    pub fn kill_all(&mut self) {
        for p in &mut self.procs {
            let _ = p.child.kill();
        }
    }

    /// Waits for every worker to leave after being told the run is over,
    /// killing those that do not within a few seconds; returns how many it
    /// killed. A worker not in `told` never joined (a short
    /// run can end before a slow worker announces itself), so nothing told
    /// it the run is over: it gets SIGTERM at once rather than the wait.
    pub fn stop_all(&mut self, told: &[ChildId]) -> usize {
        for p in &self.procs {
            if !told.contains(&p.child_id()) {
                terminate(p.child.id());
            }
        }
        // Workers told to leave exit within a couple of milliseconds: each
        // is reaped as it exits, and not looked at once more after the
        // last has gone.
        let patience = Instant::now() + Duration::from_secs(5);
        loop {
            self.exited();
            if self.procs.is_empty() || Instant::now() >= patience {
                break;
            }
            let live: Vec<u32> = self.procs.iter().map(|p| p.child.id()).collect();
            sleep_until_one_exits(&live, patience);
        }
        let stuck = self.procs.len();
        for mut p in self.procs.drain(..) {
            let _ = p.child.kill();
            let _ = p.child.wait();
        }
        stuck
    }
}

/// A file descriptor naming process `pid` (pidfd_open(2)), and no later
/// process given the same pid; `None` if there is no such process, or the
/// kernel (before 5.3) has no pidfds.
fn pidfd(pid: u32) -> Option<OwnedFd> {
    let raw = libc::pid_t::try_from(pid).ok()?;
    // SAFETY: pidfd_open takes a pid and flags and returns a new file
    // descriptor, or -1 without side effects.
    let fd = unsafe { libc::syscall(libc::SYS_pidfd_open, raw, 0) };
    let fd = i32::try_from(fd).ok().filter(|&fd| fd >= 0)?;
    // SAFETY: `fd` was just opened and nothing else owns it.
    Some(unsafe { OwnedFd::from_raw_fd(fd) })
}

/// Sleeps until one of `pids`, children of this process not yet reaped
/// (so that no pid can have been reused), exits, or until `until`.
/// Their pidfds wake it at the exit itself, where looking every
/// millisecond would wake it up to a millisecond late, and often before
/// then on the CPU an exiting worker needs. Without pidfds it sleeps a
/// millisecond.
fn sleep_until_one_exits(pids: &[u32], until: Instant) {
    let left = until.saturating_duration_since(Instant::now());
    let fds: Option<Vec<OwnedFd>> = pids.iter().map(|&pid| pidfd(pid)).collect();
    let Some(fds) = fds.filter(|fds| !fds.is_empty()) else {
        std::thread::sleep(left.min(Duration::from_millis(1)));
        return;
    };
    let mut polls: Vec<libc::pollfd> = fds
        .iter()
        .map(|fd| libc::pollfd {
            fd: fd.as_raw_fd(),
            events: libc::POLLIN,
            revents: 0,
        })
        .collect();
    // poll(2) counts whole milliseconds: round up, so as not to wake
    // before `until` and look once more for nothing.
    let ms = i32::try_from(left.as_micros().div_ceil(1000)).unwrap_or(i32::MAX);
    // One a worker: far inside nfds_t.
    let count = polls.len() as libc::nfds_t;
    // SAFETY: `polls` holds `count` initialised pollfds, each naming a
    // pidfd that `fds` keeps open for the call.
    unsafe { libc::poll(polls.as_mut_ptr(), count, ms) };
}

/// Sends SIGTERM to `pid`, a child of this process not yet reaped, so that
/// its pid cannot have been reused.
fn terminate(pid: u32) {
    if let Ok(pid) = libc::pid_t::try_from(pid) {
        // SAFETY: kill(2) takes a pid and a signal number and has no other
        // effect on this process.
        unsafe { libc::kill(pid, libc::SIGTERM) };
    }
}

/// The live (not zombie) `lander-worker` processes whose parent is
/// `parent`, read from /proc: for tools and tests that disturb workers
/// they did not spawn through `Children`.
pub fn worker_children(parent: u32) -> Vec<u32> {
    let parent = parent.to_string();
    let Ok(dir) = std::fs::read_dir("/proc") else {
        return Vec::new();
    };
    dir.flatten()
        .filter_map(|e| e.file_name().to_str()?.parse::<u32>().ok())
        .filter(|&pid| is_worker_child(&parent, pid))
        .collect()
}

/// Whether `pid` is a live `lander-worker` whose parent is `parent`.
fn is_worker_child(parent: &str, pid: u32) -> bool {
    let Ok(stat) = std::fs::read_to_string(format!("/proc/{pid}/stat")) else {
        return false;
    };
    // pid (comm) state ppid …; comm may hold spaces, so split at the last ')'.
    let Some((head, tail)) = stat.rsplit_once(')') else {
        return false;
    };
    let mut fields = tail.split_whitespace();
    let state = fields.next();
    head.ends_with("(lander-worker") && state != Some("Z") && fields.next() == Some(parent)
}

/// SIGKILLs `pid` if it is a live `lander-worker` child of `parent`; true
/// if it did. The check and the kill go through one pidfd, which names the
/// process it was opened on and no later one: a pid freed by a reaped
/// worker and reused by another process is never hit.
pub fn kill_worker_child(parent: u32, pid: u32) -> bool {
    let Some(fd) = pidfd(pid) else {
        return false;
    };
    if !is_worker_child(&parent.to_string(), pid) {
        return false;
    }
    // SAFETY: a valid pidfd, a signal number, no siginfo, no flags.
    let sent = unsafe {
        libc::syscall(
            libc::SYS_pidfd_send_signal,
            fd.as_raw_fd(),
            libc::SIGKILL,
            std::ptr::null::<libc::siginfo_t>(),
            0,
        )
    };
    sent == 0
}

/// A stand-in worker written into `dir`: it never announces itself and
/// would take 30 s to end on its own.
#[cfg(test)]
pub(super) fn stand_in_worker(dir: &std::path::Path) -> PathBuf {
    script(&dir.join("worker.sh"), "exec sleep 30\n")
}

/// A shell script of `body` written at `path`, executable, and ready to
/// run (as `lander_tests::script`, which the coordinator's own tests
/// cannot reach): a process another test forked while the file was open for writing
/// holds it open until that process execs, and until then running the
/// file fails as busy (ETXTBSY). So the script is run once first, with
/// `ready`, which ends it at once; after that no such copy is left, and
/// none can be made, this process having closed the file.
#[cfg(test)]
pub(crate) fn script(path: &std::path::Path, body: &str) -> PathBuf {
    use std::os::unix::fs::PermissionsExt;
    let text = format!("#!/bin/sh\n[ \"$1\" = ready ] && exit 0\n{body}");
    std::fs::write(path, text).unwrap();
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o755)).unwrap();
    for _ in 0..1000 {
        match std::process::Command::new(path).arg("ready").status() {
            Err(e) if e.kind() == std::io::ErrorKind::ExecutableFileBusy => {
                std::thread::sleep(std::time::Duration::from_millis(1));
            }
            ran => {
                assert!(ran.unwrap().success(), "{} cannot run", path.display());
                return path.to_path_buf();
            }
        }
    }
    panic!("{} stayed busy for a second", path.display());
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_worker_that_never_joined_is_terminated_not_waited_for_and_killed() {
        let dir = tempfile::tempdir().unwrap();
        let exe = stand_in_worker(dir.path());
        let mut children = Children::new(exe, "r".into(), Vec::new(), 0, Placement::default());
        children.spawn().unwrap();
        children.spawn().unwrap();
        assert_eq!(children.stop_all(&[]), 0, "a worker had to be killed");
        assert!(children.is_empty());
    }

    #[test]
    fn workers_told_to_leave_are_each_reaped_as_they_exit_and_none_is_killed() {
        let dir = tempfile::tempdir().unwrap();
        let exe = script(&dir.path().join("worker.sh"), "sleep 0.2\n");
        let mut children = Children::new(exe, "r".into(), Vec::new(), 0, Placement::default());
        let told = [children.spawn().unwrap(), children.spawn().unwrap()];
        let pids: Vec<u32> = told.iter().map(|c| c.pid).collect();
        // Woken by the exit, not by the end of its patience: a wait that
        // slept it out would take 60 s.
        let waited = Instant::now();
        children.await_exit(&pids[..1], Duration::from_secs(60));
        assert!(
            waited.elapsed() < Duration::from_secs(30),
            "slept to the end"
        );
        // Both sleep alike, so the second may have gone by now too.
        assert!(children.exited().contains(&told[0]), "the first waited for");
        // stop_all would take its 5 s of patience likewise.
        let stopping = Instant::now();
        assert_eq!(children.stop_all(&told), 0, "a worker had to be killed");
        assert!(
            stopping.elapsed() < Duration::from_secs(4),
            "slept to the end"
        );
        assert!(children.is_empty());
    }

    #[test]
    fn a_worker_of_another_host_with_a_childs_pid_is_not_taken_for_it() {
        let dir = tempfile::tempdir().unwrap();
        let exe = stand_in_worker(dir.path());
        let allowed = lander_protocol::host::allowed_cpus();
        let placement = Placement::new(1, &allowed[..1], true, Duration::ZERO);
        let mut children = Children::new(exe, "r".into(), Vec::new(), 0, placement);
        let child = children.spawn().unwrap();
        // The same pid under another id: a worker elsewhere, or one started
        // by hand.
        let stranger = ChildId {
            id: child.id + 0x5eed,
            ..child
        };
        assert!(children.started(child) && !children.started(stranger));
        assert!(children.beside_coordinator(child));
        assert!(!children.beside_coordinator(stranger));
        children.kill(stranger);
        std::thread::sleep(Duration::from_millis(50));
        assert!(
            children.exited().is_empty(),
            "the stranger's kill reached the child"
        );
        children.kill(child);
        assert!(
            (0..1000).any(|_| {
                std::thread::sleep(Duration::from_millis(5));
                children.exited() == [child]
            }),
            "the child was not killed"
        );
    }
}
