//! A raw iceoryx2 hop, as the baseline of the injector hop: the same services, payload and
//! event-driven waits as a co-simulation, but a second process that only echoes.
//!
//! Method (as iceoryx2's own benchmarks): ping-pong, warm-up first, then many iterations. The
//! one-way hop is measured like the co-simulation's injector stage, from publish to publish:
//! the echo's publish stamp minus the ping's publish stamp (`CLOCK_MONOTONIC`, shared by both
//! processes), so the two figures mean the same thing.
use crate::ipc::{wait, Endpoint, Inlet, Outlet};
use crate::CosimError;
use platoon_wire::{LinkPacket, Node, Service};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The step number that tells the echo to exit.
const QUIT: u64 = u64::MAX;

/// Runs `warmup + iterations` ping-pongs of `items` link packets with a `platoon node echo`
/// process started from `exe`; returns the one-way hop of each measured iteration (ns).
pub fn raw_hop(
    run_id: &str,
    exe: &Path,
    iterations: usize,
    warmup: usize,
    items: usize,
    busy: bool,
) -> Result<Vec<u64>, CosimError> {
    let e = Endpoint::new(run_id, Node::Controller)?;
    let _wake = [Node::Controller, Node::Injector]
        .iter()
        .map(|&n| e.wake_service(n, true))
        .collect::<Result<Vec<_>, _>>()?;
    let tx_service = e.create_step_service::<LinkPacket>(Service::Tx)?;
    let rx_service = e.create_step_service::<LinkPacket>(Service::Rx)?;
    let listener = e.listener()?;
    let tx: Outlet<LinkPacket> = e.outlet(&tx_service, Service::Tx, items)?;
    let mut rx: Inlet<LinkPacket> = Inlet::new(&rx_service, Node::Injector)?;
    let mut cmd = Command::new(exe);
    cmd.args(["node", "echo", "--run-id", run_id, "--config", "-"]);
    if busy {
        cmd.arg("--busy");
    }
    let mut child = cmd
        .stdin(Stdio::null())
        .spawn()
        .map_err(|source| CosimError::Spawn {
            node: "echo",
            command: format!("{} node echo", exe.display()),
            source,
        })?;
    let batch = vec![LinkPacket::default(); items];
    let mut hops = Vec::with_capacity(iterations);
    let result = (|| {
        // Until the echo is up, a ping may go unanswered: resend every 100 ms.
        let started = Instant::now();
        loop {
            tx.send(0, 0.0, &batch)?;
            wait(&listener, Duration::from_millis(100))?;
            if rx.take(0)?.is_some() {
                break;
            }
            if let Ok(Some(status)) = child.try_wait() {
                return Err(CosimError::Died {
                    node: "echo",
                    pid: child.id(),
                    step: 0,
                    status: status.to_string(),
                    detail: String::new(),
                });
            }
            if started.elapsed() > Duration::from_secs(30) {
                return Err(CosimError::Stalled {
                    node: "echo",
                    step: 0,
                    waited_s: 30.0,
                    what: "it never answered",
                    duplicates: 0,
                    detail: String::new(),
                });
            }
        }
        for i in 1..=(warmup + iterations) as u64 {
            let sent = tx.send(i, 0.0, &batch)?;
            let mut spins = 0u64;
            let echoed = loop {
                if let Some((h, _)) = rx.take_sample(i)? {
                    break h.stamp_ns;
                }
                if busy && spins < 10_000_000 {
                    spins += 1;
                    std::hint::spin_loop();
                    continue;
                }
                spins = 0;
                wait(&listener, Duration::from_secs(1))?;
                if let Ok(Some(status)) = child.try_wait() {
                    return Err(CosimError::Died {
                        node: "echo",
                        pid: child.id(),
                        step: i,
                        status: status.to_string(),
                        detail: String::new(),
                    });
                }
            };
            if i as usize > warmup {
                hops.push(echoed.saturating_sub(sent));
            }
        }
        Ok(())
    })();
    let _ = tx.send(QUIT, 0.0, &[]);
    let until = Instant::now() + Duration::from_secs(2);
    while Instant::now() < until && !matches!(child.try_wait(), Ok(Some(_))) {
        std::thread::sleep(Duration::from_millis(5));
    }
    let _ = child.kill();
    let _ = child.wait();
    // This process was a node (the echo's wake-ups narrowed it): what it starts next must not
    // inherit that CPU.
    crate::handoff::go_home();
    result?;
    Ok(hops)
}

/// The echo process: republishes every tx sample on rx, until told to quit or orphaned. With
/// `busy` it polls instead of waiting (opt-in: it burns a core).
pub fn echo(run_id: &str, busy: bool) -> Result<(), CosimError> {
    let e = Endpoint::new(run_id, Node::Injector)?;
    let listener = e.listener()?;
    let mut tx: Inlet<LinkPacket> =
        Inlet::new(&e.open_step_service(Service::Tx)?, Node::Controller)?;
    let rx: Outlet<LinkPacket> = e.outlet(&e.open_step_service(Service::Rx)?, Service::Rx, 64)?;
    let parent = std::os::unix::process::parent_id();
    loop {
        tx.drain()?;
        while let Some((h, items)) = tx.pop() {
            if h.step == QUIT {
                return Ok(());
            }
            rx.send(h.step, 0.0, &items)?;
        }
        if busy {
            for _ in 0..1000 {
                std::hint::spin_loop();
            }
        } else {
            wait(&listener, Duration::from_millis(200))?;
        }
        if std::os::unix::process::parent_id() != parent {
            return Err(CosimError::Orphaned);
        }
    }
}

/// A socket baseline for the hop.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Socket {
    /// UDP on 127.0.0.1.
    Udp,
    /// A Unix domain datagram socket.
    Uds,
}

impl Socket {
    /// Its name in `platoon node echo-<name>`.
    pub fn name(self) -> &'static str {
        match self {
            Socket::Udp => "udp",
            Socket::Uds => "uds",
        }
    }
}

/// Sends a datagram and receives the echo into the same buffer.
type SendRecv = dyn FnMut(&mut [u8]) -> std::io::Result<usize>;

/// The same ping-pong over a socket: `bytes` of payload, the echo in another process
/// (`platoon node echo-udp|echo-uds`), blocking (kernel-woken) receives. The hop is publish to
/// publish, as for iceoryx2: the echo's send stamp minus ours, both in the datagram.
pub fn socket_hop(
    socket: Socket,
    exe: &Path,
    iterations: usize,
    warmup: usize,
    bytes: usize,
) -> std::io::Result<Vec<u64>> {
    use std::io::{BufRead, BufReader, Error, ErrorKind};
    let dir = std::env::temp_dir().join(format!("platoon-bench-{}", crate::new_run_id()));
    std::fs::create_dir_all(&dir)?;
    let mut child = Command::new(exe)
        .args([
            "node",
            &format!("echo-{}", socket.name()),
            "--run-id",
            "-",
            "--config",
        ])
        .arg(dir.join("echo.sock"))
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .spawn()?;
    let mut line = String::new();
    BufReader::new(child.stdout.take().expect("piped")).read_line(&mut line)?;
    let address = line.trim().to_string();
    let timeout = Some(Duration::from_secs(2));
    let mut buf = vec![0u8; bytes.max(16) + 16];
    let mut hops = Vec::with_capacity(iterations);
    let result = (|| -> std::io::Result<()> {
        // Either socket: connected to the echo, with the same timeout and payload length.
        macro_rules! connected {
            ($s:expr) => {{
                let s = $s;
                s.connect(&address)?;
                s.set_read_timeout(timeout)?;
                let len = bytes.max(16);
                Box::new(move |b: &mut [u8]| {
                    s.send(&b[..len])?;
                    s.recv(b)
                }) as Box<SendRecv>
            }};
        }
        let send_recv = match socket {
            Socket::Udp => connected!(std::net::UdpSocket::bind("127.0.0.1:0")?),
            Socket::Uds => connected!(std::os::unix::net::UnixDatagram::bind(
                dir.join("ping.sock")
            )?),
        };
        let mut send_recv = send_recv;
        if line.is_empty() {
            return Err(Error::other("the echo process did not start"));
        }
        for i in 0..warmup + iterations {
            let sent = crate::monotonic_ns();
            buf[..8].copy_from_slice(&sent.to_le_bytes());
            let n = send_recv(&mut buf)?;
            if n < 16 {
                return Err(Error::new(ErrorKind::InvalidData, "short echo"));
            }
            let echoed = u64::from_le_bytes(buf[8..16].try_into().expect("8 bytes"));
            if i >= warmup {
                hops.push(echoed.saturating_sub(sent));
            }
        }
        Ok(())
    })();
    let _ = child.kill();
    let _ = child.wait();
    let _ = std::fs::remove_dir_all(&dir);
    result.map(|_| hops)
}

/// The socket echo process: prints its address, then answers every datagram with the sender's
/// stamp and its own (bytes 8..16), until orphaned.
pub fn socket_echo(socket: Socket, path: &Path) -> std::io::Result<()> {
    let tick = Some(Duration::from_millis(200));
    match socket {
        Socket::Udp => {
            let s = std::net::UdpSocket::bind("127.0.0.1:0")?;
            s.set_read_timeout(tick)?;
            serve_echo(&s.local_addr()?.to_string(), |buf| {
                let (n, from) = s.recv_from(buf)?;
                stamp(buf);
                s.send_to(&buf[..n], from).map(|_| ())
            })
        }
        Socket::Uds => {
            let s = std::os::unix::net::UnixDatagram::bind(path)?;
            s.set_read_timeout(tick)?;
            serve_echo(&path.display().to_string(), |buf| {
                let (n, from) = s.recv_from(buf)?;
                stamp(buf);
                match from.as_pathname() {
                    Some(p) => s.send_to(&buf[..n], p).map(|_| ()),
                    None => Ok(()),
                }
            })
        }
    }
}

/// The echo's stamp, after the sender's.
fn stamp(buf: &mut [u8]) {
    buf[8..16].copy_from_slice(&crate::monotonic_ns().to_le_bytes());
}

/// Prints `address`, then runs `echo_one` (which answers one datagram, or times out) until the
/// parent process is gone.
fn serve_echo(
    address: &str,
    mut echo_one: impl FnMut(&mut [u8]) -> std::io::Result<()>,
) -> std::io::Result<()> {
    use std::io::{ErrorKind, Write};
    let parent = std::os::unix::process::parent_id();
    println!("{address}");
    std::io::stdout().flush()?;
    let mut buf = vec![0u8; 1 << 16];
    loop {
        match echo_one(&mut buf) {
            Ok(()) => {}
            Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {}
            Err(e) => return Err(e),
        }
        if std::os::unix::process::parent_id() != parent {
            return Ok(());
        }
    }
}
