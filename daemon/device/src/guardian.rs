//! The dead man's switch: a guardian process that outlives hapticd and drives its amplifiers
//! to zero current when hapticd dies without doing so itself.
//!
//! A dying process cannot be trusted to run code: SIGKILL, the OOM killer, an `exit()` or
//! `abort()` inside a plugin's constructor end it wherever it is, with the last D/A command
//! still applied by the amplifier (which holds its outputs until told otherwise). So hapticd
//! starts the guardian first of all (its own executable again, named [`PROGRAM`]), hands it
//! a pidfd of itself, tells it over a socket which amplifier nodes and traffic recordings it
//! drives, and tells it when it has stopped the motors itself. The guardian holds that
//! pidfd: once it becomes
//! readable (the kernel has then closed every file of the dead process, so the amplifier's
//! interface is free) and no orderly stop was announced, it opens the amplifier's interface,
//! sends one zero-current command, appends the same command to the traffic recording (the
//! simulator's amplifier is that recording), and exits.
//!
//! A daemon can also stop without dying (SIGSTOP, a debugger, a hang): then its files stay
//! open and its last command stays applied. So each device's real-time loop beats in memory
//! shared with the guardian (a sealed memfd handed over as the guardian's standard output,
//! which it never prints to): the ticks made so far, and whether the loop drives its motors.
//! A loop that drives and makes no tick for [`STALL`] has stalled; the motors cannot be
//! reached while the daemon holds their interface, so the guardian ends the daemon
//! (SIGKILL, which a stopped process obeys too) and zeroes them as after any death. A daemon
//! that could resume would write its stale command again: ended, it cannot.
//!
//! The guardian ignores SIGTERM, SIGINT and SIGHUP, so a stop that signals the whole service
//! (systemd's `KillMode=control-group`) cannot end it before the daemon. SIGKILL cannot be
//! ignored, and a kill of a whole control group (systemd's stop timeout, `systemctl kill -s
//! KILL hapticd`) would end a child guardian at the same instant as hapticd. So under systemd
//! the guardian is a service of its own: hapticd connects to the socket named by
//! [`SOCKET_VARIABLE`] (`hapticd-guardian.socket`), and systemd starts one guardian per
//! connection (`hapticd-guardian@.service`) in a control group of its own, which such a kill
//! does not reach. Started as a child or as a service, a guardian reads the same messages
//! on its standard input.

use std::collections::BTreeMap;
use std::fs::File;
use std::os::fd::{AsRawFd, FromRawFd, OwnedFd, RawFd};
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitCode, Stdio};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use hapticd_ipc::shared_memory::{Mapping, sealed};

mod socket;

use crate::replay::{Direction, Transfer, write_transfer};
use crate::usbfs::{UsbfsDevice, claim_interface, open_node};
use crate::{Protocol, sh4, simple};
use hapticd_core::transport::CHANNELS;

/// The name the guardian runs under (its `argv[0]`): hapticd's `main` becomes the guardian
/// when it is started so.
pub const PROGRAM: &str = "hapticd-guardian";

/// The environment variable that names the guardian service's socket; unset, hapticd starts
/// its guardian as a child.
pub const SOCKET_VARIABLE: &str = "HAPTICD_GUARDIAN_SOCKET";

/// How long a new guardian waits for the daemon's first message.
const GREETING_MS: libc::c_int = 5000;

/// How long the guardian tries to claim an amplifier whose interface is still held (the
/// dead daemon's file can outlive it for a moment in a child it forked).
const CLAIM_PATIENCE: Duration = Duration::from_secs(1);

/// Largest message on the socket: a verb, a slot, a protocol and a path.
const MAX_MESSAGE: usize = 8 + 4096;

/// How long a loop that drives its motors may go without a tick before the guardian ends
/// the daemon: a hundred periods at 1 kHz, and a hundred and fifty times the worst wake-up
/// latency of the README's `make run` (0.65 ms).
pub const STALL: Duration = Duration::from_millis(100);
/// How often the guardian looks at the beats while a loop drives.
const LOOK_MS: libc::c_int = 10;
/// Slots the shared beats have room for (a slot of another number beats nowhere).
const BEAT_SLOTS: usize = 256;

/// One slot's beat, as laid out in the shared memory.
#[repr(C)]
struct Beat {
    /// Ticks the loop has made.
    ticks: AtomicU64,
    /// 1 while the loop drives its motors, 0 once it has zeroed them and stopped.
    driving: AtomicU64,
}

/// The shared beats' mapping.
struct Beats(Mapping);

// SAFETY: the mapping is only ever read and written through the atomics of `Beat`.
unsafe impl Sync for Beats {}

impl Beats {
    /// The beats in `mapping`, if it holds them all.
    fn new(mapping: Mapping) -> Option<Self> {
        (mapping.len() >= size_of::<Beat>() * BEAT_SLOTS).then_some(Self(mapping))
    }

    fn slot(&self, slot: usize) -> &Beat {
        assert!(slot < BEAT_SLOTS);
        // SAFETY: within the mapping (its length checked when made), page-aligned and so
        // aligned for Beat; AtomicU64 may be shared, and zeroed memory is a valid Beat.
        unsafe { &*self.0.address().cast::<Beat>().add(slot) }
    }
}

/// A device loop's beat, which the guardian watches.
#[derive(Clone)]
pub struct Heartbeat {
    beats: Arc<Beats>,
    slot: usize,
}

impl Heartbeat {
    /// [rt] The loop has made `ticks` ticks and drives its motors.
    pub fn beat(&self, ticks: u64) {
        let beat = self.beats.slot(self.slot);
        beat.ticks.store(ticks, Ordering::Release);
        beat.driving.store(1, Ordering::Release);
    }

    /// [rt] The loop has zeroed its motors and stops: no more beats to wait for.
    pub fn rest(&self) {
        self.beats
            .slot(self.slot)
            .driving
            .store(0, Ordering::Release);
    }
}

/// What one message tells the guardian.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
enum Verb {
    /// Slot N is the amplifier at this usbfs node.
    Amplifier = 1,
    /// Slot N's traffic is recorded to this file.
    Recording = 2,
    /// The daemon has zeroed every motor itself and is stopping.
    Disarm = 3,
    /// The first message: the daemon's pid, with a pidfd of it and the beats' memfd.
    Hello = 4,
}

impl Verb {
    fn from_byte(byte: u8) -> Option<Self> {
        [Verb::Amplifier, Verb::Recording, Verb::Disarm, Verb::Hello]
            .into_iter()
            .find(|v| *v as u8 == byte)
    }
}

fn protocol_byte(protocol: Protocol) -> u8 {
    match protocol {
        Protocol::Sh4 => 0,
        Protocol::Simple => 1,
    }
}

fn protocol_of(byte: u8) -> Option<Protocol> {
    match byte {
        0 => Some(Protocol::Sh4),
        1 => Some(Protocol::Simple),
        _ => None,
    }
}

/// The zero-current command of `protocol`, and the OUT endpoint it goes to.
pub fn zero_current(protocol: Protocol) -> (u8, Vec<u8>) {
    let zeros = [0i16; CHANNELS];
    match protocol {
        Protocol::Sh4 => {
            let mut out = [0u8; sh4::PACKET];
            sh4::Command { dac: zeros }.encode(&mut out);
            (sh4::ENDPOINT_OUT, out.to_vec())
        }
        Protocol::Simple => {
            let mut out = [0u8; simple::PACKET];
            simple::Command::SetDac(zeros).encode(&mut out);
            (simple::ENDPOINT_OUT, out.to_vec())
        }
    }
}

/// One message: verb, slot, protocol, path.
fn message(verb: Verb, slot: u32, protocol: Protocol, path: &Path) -> Vec<u8> {
    let mut m = vec![verb as u8];
    m.extend(slot.to_le_bytes());
    m.push(protocol_byte(protocol));
    m.extend(path.as_os_str().as_encoded_bytes());
    m
}

/// The daemon's side of its guardian. Every call is on the main thread; a guardian that died
/// is started again and told everything anew.
pub struct Guardian {
    inner: Mutex<Inner>,
    beats: Arc<Beats>,
}

struct Inner {
    process: Process,
    socket: OwnedFd,
    /// The shared beats' descriptor, handed to each guardian started.
    beats_fd: OwnedFd,
    /// Every message that still holds, to tell a guardian started again.
    watched: BTreeMap<(u8, u32), (Vec<u8>, Option<OwnedFd>)>,
}

impl Guardian {
    /// [main] Start the guardian of this process.
    pub fn spawn() -> std::io::Result<Self> {
        let (beats_fd, mapping) = sealed("hapticd-heartbeats", size_of::<Beat>() * BEAT_SLOTS)?;
        let (process, socket) = start(&beats_fd)?;
        Ok(Self {
            inner: Mutex::new(Inner {
                process,
                socket,
                beats_fd,
                watched: BTreeMap::new(),
            }),
            beats: Arc::new(Beats::new(mapping).expect("mapped at the beats' size")),
        })
    }

    /// The beat of slot `slot`'s loop, if the shared memory has room for it.
    pub fn heartbeat(&self, slot: u32) -> Option<Heartbeat> {
        let slot = usize::try_from(slot).ok().filter(|&s| s < BEAT_SLOTS)?;
        Some(Heartbeat {
            beats: self.beats.clone(),
            slot,
        })
    }

    /// [main] Slot `slot` is the `protocol` amplifier at usbfs `node` (replacing what the
    /// slot was: an amplifier plugged back in may have a new node).
    pub fn watch_amplifier(&self, slot: u32, protocol: Protocol, node: &Path) {
        self.tell(message(Verb::Amplifier, slot, protocol, node), None);
    }

    /// [main] Slot `slot`'s traffic, in `protocol`, is recorded to `path`.
    pub fn watch_recording(&self, slot: u32, protocol: Protocol, path: &Path) {
        // Handed over open: a guardian service has a /tmp of its own and may write nowhere.
        let file = std::fs::OpenOptions::new().append(true).open(path).ok();
        self.tell(
            message(Verb::Recording, slot, protocol, path),
            file.map(OwnedFd::from),
        );
    }

    /// [main] The motors are at zero and the daemon is stopping in order: nothing to do when
    /// it ends. Waits (briefly) for the guardian to end, so that a daemon that starts again
    /// in the same process leaves no zombie behind.
    pub fn disarm(&self) {
        self.tell(vec![Verb::Disarm as u8], None);
        let deadline = Instant::now() + Duration::from_millis(500);
        let mut inner = lock(&self.inner);
        let inner = &mut *inner;
        while inner.process.ended(&inner.socket).is_none() && Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(2));
        }
    }

    /// [main] Start the guardian again if it has died; returns what to tell the journal.
    pub fn revive(&self) -> Option<String> {
        let mut inner = lock(&self.inner);
        let inner = &mut *inner;
        let status = inner.process.ended(&inner.socket)?;
        match start(&inner.beats_fd) {
            Ok((process, socket)) => {
                inner.process = process;
                inner.socket = socket;
                let failed = inner
                    .watched
                    .values()
                    .any(|(m, fd)| socket::send(&inner.socket, m, &raw(fd)).is_err());
                Some(format!(
                    "the guardian that zeroes the motors should hapticd die ended ({status}); \
                     started again{}",
                    if failed {
                        ", but it cannot be told what to guard"
                    } else {
                        ""
                    }
                ))
            }
            Err(e) => Some(format!(
                "the guardian that zeroes the motors should hapticd die ended ({status}) and \
                 cannot be started again: {e}"
            )),
        }
    }

    fn tell(&self, message: Vec<u8>, fd: Option<OwnedFd>) {
        let mut inner = lock(&self.inner);
        // A dead guardian is revived with the whole list; the send itself may then fail.
        let _ = socket::send(&inner.socket, &message, &raw(&fd));
        let key = (message[0], message.get(1..5).map_or(0, slot_of));
        inner.watched.insert(key, (message, fd));
    }
}

fn raw(fd: &Option<OwnedFd>) -> Vec<RawFd> {
    fd.iter().map(AsRawFd::as_raw_fd).collect()
}

fn lock(inner: &Mutex<Inner>) -> std::sync::MutexGuard<'_, Inner> {
    inner
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
}

fn slot_of(bytes: &[u8]) -> u32 {
    u32::from_le_bytes(bytes.try_into().unwrap_or_default())
}

/// A running guardian, as the daemon knows it.
enum Process {
    /// This executable again, started by the daemon.
    Child(Child),
    /// An instance of the guardian service, at the other end of the connection.
    Service,
}

impl Process {
    /// How it ended, if it has; `socket` is the daemon's end of its connection.
    fn ended(&mut self, socket: &OwnedFd) -> Option<String> {
        match self {
            Process::Child(child) => match child.try_wait() {
                Ok(None) => None,
                Ok(Some(status)) => Some(status.to_string()),
                Err(e) => Some(e.to_string()),
            },
            Process::Service => socket::hung_up(socket, 0).then(|| "its connection closed".into()),
        }
    }
}

/// Start a guardian of this process and greet it: a connection to the guardian service
/// when [`SOCKET_VARIABLE`] names its socket, else this executable again, as [`PROGRAM`],
/// its standard input one end of a socket pair. The greeting hands it a pidfd of this
/// process and the shared `beats`.
fn start(beats: &OwnedFd) -> std::io::Result<(Process, OwnedFd)> {
    let (process, ours) = match std::env::var_os(SOCKET_VARIABLE) {
        Some(path) => {
            let path = PathBuf::from(path);
            let socket = socket::connect(&path).map_err(|e| {
                std::io::Error::new(
                    e.kind(),
                    format!("the guardian service at {}: {e}", path.display()),
                )
            })?;
            (Process::Service, socket)
        }
        None => {
            let (ours, theirs) = socket::pair()?;
            let child = Command::new("/proc/self/exe")
                .arg0(PROGRAM)
                .stdin(Stdio::from(theirs))
                .stdout(Stdio::null())
                .spawn()?;
            (Process::Child(child), ours)
        }
    };
    let pidfd = pidfd_open(std::process::id() as libc::pid_t)?;
    let mut hello = vec![Verb::Hello as u8];
    hello.extend(std::process::id().to_le_bytes());
    socket::send(&ours, &hello, &[pidfd.as_raw_fd(), beats.as_raw_fd()])?;
    Ok((process, ours))
}

fn pidfd_open(pid: libc::pid_t) -> std::io::Result<OwnedFd> {
    // SAFETY: pidfd_open takes a pid and flags and returns a new descriptor or -1.
    let fd = unsafe { libc::syscall(libc::SYS_pidfd_open, pid, 0) };
    if fd < 0 {
        return Err(std::io::Error::last_os_error());
    }
    // SAFETY: pidfd_open succeeded: the descriptor is new and ours.
    Ok(unsafe { OwnedFd::from_raw_fd(fd as i32) })
}

/// The pid a pidfd refers to (its `fdinfo`), or None once that process is gone.
fn pid_of(pidfd: &OwnedFd) -> Option<libc::pid_t> {
    let info = std::fs::read_to_string(format!("/proc/self/fdinfo/{}", pidfd.as_raw_fd())).ok()?;
    info.lines()
        .find_map(|l| l.strip_prefix("Pid:"))
        .and_then(|p| p.trim().parse().ok())
        .filter(|&p: &libc::pid_t| p > 0)
}

/// The daemon this guardian guards, as its greeting on standard input names it.
/// Why the guardian has no daemon to guard.
#[derive(Debug)]
enum GreetingError {
    /// Nothing came on the socket in time.
    Silent,
    /// The first message is something else.
    NotAGreeting,
    /// The greeting lacks the pidfd and the beats.
    NoDescriptors,
    /// The socket failed.
    Socket(std::io::Error),
    /// The greeting names another process than the one that sent it.
    Impostor {
        /// The pid the greeting names.
        named: libc::pid_t,
        /// The pid at the other end of the socket.
        peer: libc::pid_t,
    },
}

impl std::fmt::Display for GreetingError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            GreetingError::Silent => f.write_str("no greeting on its standard input"),
            GreetingError::NotAGreeting => f.write_str("its first message is no greeting"),
            GreetingError::NoDescriptors => f.write_str("the greeting carries no pidfd and beats"),
            GreetingError::Socket(e) => e.fmt(f),
            GreetingError::Impostor { named, peer } => write!(
                f,
                "the greeting names pid {named}, from pid {peer}: not the process that sent it"
            ),
        }
    }
}

struct Daemon {
    pid: libc::pid_t,
    pidfd: OwnedFd,
    beats: OwnedFd,
}

impl Daemon {
    /// Wait for the greeting on `socket`; an error says why there is no daemon to guard.
    /// The pidfd must be of the process at the other end of the socket, so a greeting
    /// cannot name another process.
    fn greeted(socket: RawFd) -> Result<Self, GreetingError> {
        let mut fds = [libc::pollfd {
            fd: socket,
            events: libc::POLLIN,
            revents: 0,
        }];
        // SAFETY: poll reads and writes the one pollfd that lives across the call.
        if unsafe { libc::poll(fds.as_mut_ptr(), 1, GREETING_MS) } <= 0 {
            return Err(GreetingError::Silent);
        }
        let mut buffer = [0u8; 16];
        let (n, descriptors) =
            socket::receive(socket, &mut buffer).map_err(GreetingError::Socket)?;
        let pid = match &buffer[..n] {
            [verb, pid @ ..] if *verb == Verb::Hello as u8 && pid.len() == 4 => {
                slot_of(pid) as libc::pid_t
            }
            _ => return Err(GreetingError::NotAGreeting),
        };
        let [pidfd, beats]: [OwnedFd; 2] = descriptors
            .try_into()
            .map_err(|_| GreetingError::NoDescriptors)?;
        let peer = socket::peer_pid(socket).map_err(GreetingError::Socket)?;
        if pid_of(&pidfd) != Some(pid) || peer != pid {
            return Err(GreetingError::Impostor { named: pid, peer });
        }
        Ok(Self { pid, pidfd, beats })
    }
}

/// Whether this process was started as the guardian.
pub fn is_guardian() -> bool {
    std::env::args_os()
        .next()
        .is_some_and(|name| Path::new(&name).file_name() == Some(PROGRAM.as_ref()))
}

/// What the guardian holds for one slot.
#[derive(Default)]
struct Slot {
    amplifier: Option<(Protocol, PathBuf, File)>,
    recording: Option<(Protocol, PathBuf, File)>,
}

/// The guardian's whole life: guard the daemon that greets it on its standard input, from
/// the messages that follow, until it ends.
pub fn run() -> ExitCode {
    ignore_stop_signals();
    let Daemon {
        pid: daemon,
        pidfd,
        beats,
    } = match Daemon::greeted(0) {
        Ok(daemon) => daemon,
        Err(e) => {
            eprintln!(
                "{PROGRAM}: {e}. It guards the hapticd that starts it, or that connects to \
                 its service's socket"
            );
            return ExitCode::FAILURE;
        }
    };
    // SAFETY: mlockall takes no pointers; failing only means the guardian may page-fault.
    unsafe { libc::mlockall(libc::MCL_CURRENT | libc::MCL_FUTURE) };
    let mut slots: BTreeMap<u32, Slot> = BTreeMap::new();
    let mut buffer = vec![0u8; MAX_MESSAGE];
    let mut watch = Watch::of(&beats);
    loop {
        let mut fds = [
            libc::pollfd {
                fd: 0,
                events: libc::POLLIN,
                revents: 0,
            },
            libc::pollfd {
                fd: pidfd.as_raw_fd(),
                events: libc::POLLIN,
                revents: 0,
            },
        ];
        // Beats are looked at while there is something to zero (a loop starts driving after
        // the guardian has been told what it drives).
        let timeout = if watch.beats.is_some() && !slots.is_empty() {
            LOOK_MS
        } else {
            -1
        };
        // SAFETY: poll reads and writes the two pollfds that live across the call.
        if unsafe { libc::poll(fds.as_mut_ptr(), 2, timeout) } < 0 {
            continue;
        }
        if fds[1].revents != 0 {
            break;
        }
        if let Some((slot, quiet)) = watch.stalled(Instant::now())
            && !slots.is_empty()
        {
            end_stalled(daemon, &pidfd, slot, quiet);
            break;
        }
        if fds[0].revents == 0 {
            continue;
        }
        let Ok((n, descriptors)) = socket::receive(0, &mut buffer) else {
            break;
        };
        if n == 0 {
            // The daemon's end closed: it died, or replaced its image (it announces that
            // with Disarm first, having zeroed its motors).
            break;
        }
        if apply(&buffer[..n], descriptors, &mut slots) {
            return ExitCode::SUCCESS;
        }
    }
    zero_everything(daemon, slots);
    ExitCode::SUCCESS
}

/// The guardian's view of the shared beats: each slot's last tick count and when it
/// changed.
struct Watch {
    beats: Option<Beats>,
    seen: Vec<Option<(u64, Instant)>>,
}

impl Watch {
    /// The beats in the memfd `fd` (none when it cannot be mapped whole).
    fn of(fd: &OwnedFd) -> Self {
        let beats = Mapping::read_only(fd).ok().and_then(Beats::new);
        Self {
            beats,
            seen: vec![None; BEAT_SLOTS],
        }
    }

    /// A slot whose loop drives and has made no tick for [`STALL`] by `now`, and how long it
    /// has been quiet.
    fn stalled(&mut self, now: Instant) -> Option<(usize, Duration)> {
        let beats = self.beats.as_ref()?;
        for (slot, seen) in self.seen.iter_mut().enumerate() {
            let beat = beats.slot(slot);
            if beat.driving.load(Ordering::Acquire) != 1 {
                *seen = None;
                continue;
            }
            let ticks = beat.ticks.load(Ordering::Acquire);
            match seen {
                Some((last, since)) if *last == ticks => {
                    let quiet = now.duration_since(*since);
                    if quiet >= STALL {
                        return Some((slot, quiet));
                    }
                }
                _ => *seen = Some((ticks, now)),
            }
        }
        None
    }
}

/// The daemon's loop on `slot` has stalled for `quiet` while driving: end the daemon (its
/// files close, its claims on the amplifiers go) and wait, briefly, until it has ended.
fn end_stalled(daemon: libc::pid_t, pidfd: &OwnedFd, slot: usize, quiet: Duration) {
    let state = std::fs::read_to_string(format!("/proc/{daemon}/stat"))
        .ok()
        .and_then(|s| s.rsplit_once(") ").map(|(_, rest)| rest.chars().next()))
        .flatten()
        .map_or("gone", |c| match c {
            'T' | 't' => "stopped",
            'D' => "waiting on the kernel",
            _ => "running",
        });
    eprintln!(
        "{PROGRAM}: hapticd (pid {daemon}) made no haptic tick on device slot {slot} for {} ms while driving its motors (its process is {state}): ended, to zero them",
        quiet.as_millis()
    );
    // SAFETY: a signal to the process the pidfd holds, whatever its pid is by now.
    unsafe {
        libc::syscall(
            libc::SYS_pidfd_send_signal,
            pidfd.as_raw_fd(),
            libc::SIGKILL,
            0,
            0,
        )
    };
    let mut fds = [libc::pollfd {
        fd: pidfd.as_raw_fd(),
        events: libc::POLLIN,
        revents: 0,
    }];
    // SAFETY: poll reads and writes the one pollfd that lives across the call.
    unsafe { libc::poll(fds.as_mut_ptr(), 1, 2000) };
}

/// Take in one message and the descriptors it carried; true when it is the orderly stop.
fn apply(message: &[u8], descriptors: Vec<OwnedFd>, slots: &mut BTreeMap<u32, Slot>) -> bool {
    let verb = message.first().copied().and_then(Verb::from_byte);
    if verb == Some(Verb::Disarm) {
        return true;
    }
    let (Some(verb), Some(slot), Some(protocol)) = (
        verb,
        message.get(1..5).map(slot_of),
        message.get(5).copied().and_then(protocol_of),
    ) else {
        eprintln!("{PROGRAM}: a message it does not understand, ignored");
        return false;
    };
    // SAFETY: the bytes were encoded from an OsStr by the daemon (same platform).
    let path =
        PathBuf::from(unsafe { std::ffi::OsStr::from_encoded_bytes_unchecked(&message[6..]) });
    let entry = slots.entry(slot).or_default();
    match verb {
        Verb::Amplifier => match open_node(&path) {
            Ok(file) => entry.amplifier = Some((protocol, path, file)),
            Err(e) => eprintln!("{PROGRAM}: cannot open {}: {e}", path.display()),
        },
        Verb::Recording => match descriptors.into_iter().next().map_or_else(
            || std::fs::OpenOptions::new().append(true).open(&path),
            |fd| Ok(File::from(fd)),
        ) {
            Ok(file) => entry.recording = Some((protocol, path, file)),
            Err(e) => eprintln!("{PROGRAM}: cannot open {}: {e}", path.display()),
        },
        Verb::Disarm => unreachable!("handled above"),
        Verb::Hello => eprintln!("{PROGRAM}: a second greeting, ignored"),
    }
    false
}

/// The daemon died without stopping its motors: zero every amplifier and recording.
fn zero_everything(daemon: libc::pid_t, slots: BTreeMap<u32, Slot>) {
    for slot in slots.into_values() {
        if let Some((protocol, node, file)) = slot.amplifier {
            match zero_amplifier(protocol, file) {
                Ok(()) => eprintln!(
                    "{PROGRAM}: hapticd (pid {daemon}) ended without stopping its motors: \
                     sent zero current to {}",
                    node.display()
                ),
                Err(e) => eprintln!(
                    "{PROGRAM}: hapticd (pid {daemon}) ended without stopping its motors, and \
                     zero current could not be sent to {}: {e}",
                    node.display()
                ),
            }
        }
        if let Some((protocol, path, mut file)) = slot.recording {
            let (_, zero) = zero_current(protocol);
            match write_transfer(&mut file, &Transfer::new(Direction::Out, &zero)) {
                Ok(()) => eprintln!(
                    "{PROGRAM}: hapticd (pid {daemon}) ended without stopping its motors: \
                     zero current recorded to {}",
                    path.display()
                ),
                Err(e) => eprintln!("{PROGRAM}: cannot append to {}: {e}", path.display()),
            }
        }
    }
}

/// Claim the amplifier's interface (free once the daemon's files are closed) and send it the
/// zero-current command. The node opened at the start serves: a duplicate of it would do as
/// well with the kernel, but not under umockdev, which follows no `dup`.
fn zero_amplifier(protocol: Protocol, node: File) -> std::io::Result<()> {
    let (endpoint, zero) = zero_current(protocol);
    let deadline = Instant::now() + CLAIM_PATIENCE;
    loop {
        match claim_interface(&node, 0) {
            Ok(()) => break,
            Err(e) if e.raw_os_error() == Some(libc::EBUSY) && Instant::now() < deadline => {
                std::thread::sleep(Duration::from_millis(10));
            }
            Err(e) => return Err(e),
        }
    }
    UsbfsDevice::claimed(node, 0, Duration::from_millis(100))
        .write(endpoint, &zero)
        .map_err(|e| std::io::Error::other(format!("{e:?}")))
}

/// SIGTERM, SIGINT and SIGHUP reach every process of a stopping service at once: the
/// guardian outlives them, and ends by itself once the daemon has.
fn ignore_stop_signals() {
    for signal in [libc::SIGTERM, libc::SIGINT, libc::SIGHUP] {
        // SAFETY: SIG_IGN installs no handler code.
        unsafe { libc::signal(signal, libc::SIG_IGN) };
    }
}

#[cfg(test)]
mod tests;
