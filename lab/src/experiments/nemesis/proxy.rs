//! The nemesis's delaying TCP proxy: the delay and jitter `tc netem` would add, which this
//! kernel lacks.
//!
//! It listens, and for every connection accepted opens one to the upstream (the router)
//! and copies both ways. While a delay is set for the connection's peer address, every
//! chunk read is held for the delay plus a jitter drawn uniformly from plus or minus the
//! jitter (from a seeded generator), and never overtakes the chunk before it.
//!
//! What it is not: a link emulator below TCP. It delays a byte stream, so jitter spreads
//! arrivals without reordering them (netem reorders packets, which TCP would then put
//! back in order at the cost of retransmissions not modelled here), and each of the two
//! TCP connections sees neither loss nor delay of its own. What the fleet above sees is
//! the same: every message from and to the unit late by the delay, unevenly.
//!
//! Controlled on stdin, a command a line: `delay <peer ip> <ms> <jitter ms>` and `clear`.
//! It exits when stdin closes, so it never outlives the harness that started it.

use std::collections::HashMap;
use std::net::{IpAddr, SocketAddr};
use std::process::ExitCode;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use anyhow::{Context, bail};
use clap::Args;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use tokio::io::{AsyncBufReadExt, AsyncReadExt, AsyncWriteExt, BufReader};
use tokio::net::tcp::{OwnedReadHalf, OwnedWriteHalf};
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::mpsc;
use tokio::time::Instant;

#[derive(Args, Debug)]
pub struct ProxyArgs {
    /// Where to listen.
    #[arg(long)]
    listen: SocketAddr,
    /// Where every connection is forwarded.
    #[arg(long)]
    upstream: SocketAddr,
    /// Seed of the jitter.
    #[arg(long, default_value_t = 0)]
    seed: u64,
}

/// The delay set for one peer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Delay {
    pub delay: Duration,
    /// Half the width of the uniform spread around `delay`.
    pub jitter: Duration,
}

/// The delays in force, by peer address, and the generator of their jitter.
#[derive(Clone)]
pub struct Delays(Arc<Mutex<(HashMap<IpAddr, Delay>, ChaCha8Rng)>>);

impl Delays {
    pub fn new(seed: u64) -> Self {
        Self(Arc::new(Mutex::new((
            HashMap::new(),
            ChaCha8Rng::seed_from_u64(seed),
        ))))
    }

    pub fn set(&self, peer: IpAddr, delay: Option<Delay>) {
        let mut d = self.0.lock().expect("no holder panics");
        match delay {
            Some(delay) => d.0.insert(peer, delay),
            None => d.0.remove(&peer),
        };
    }

    fn clear(&self) {
        self.0.lock().expect("no holder panics").0.clear();
    }

    /// How long to hold what `peer`'s connection carries now.
    fn hold(&self, peer: IpAddr) -> Duration {
        let mut guard = self.0.lock().expect("no holder panics");
        let (delays, rng) = &mut *guard;
        let Some(d) = delays.get(&peer) else {
            return Duration::ZERO;
        };
        let j = d.jitter.as_secs_f64();
        let spread = if j > 0.0 {
            rng.random_range(-j..=j)
        } else {
            0.0
        };
        Duration::from_secs_f64((d.delay.as_secs_f64() + spread).max(0.0))
    }
}

/// One line of the control protocol.
fn command(line: &str, delays: &Delays) -> anyhow::Result<()> {
    let words: Vec<&str> = line.split_whitespace().collect();
    match words.as_slice() {
        ["delay", peer, ms, jitter] => {
            let peer: IpAddr = peer.parse().with_context(|| format!("peer '{peer}'"))?;
            let ms: u64 = ms.parse().with_context(|| format!("delay '{ms}'"))?;
            let jitter: u64 = jitter
                .parse()
                .with_context(|| format!("jitter '{jitter}'"))?;
            if jitter > ms {
                bail!("jitter {jitter} ms is above the delay {ms} ms");
            }
            delays.set(
                peer,
                Some(Delay {
                    delay: Duration::from_millis(ms),
                    jitter: Duration::from_millis(jitter),
                }),
            );
        }
        ["clear"] => delays.clear(),
        [] => {}
        _ => bail!("expected 'delay <peer ip> <ms> <jitter ms>' or 'clear'"),
    }
    Ok(())
}

pub async fn run(a: ProxyArgs) -> anyhow::Result<ExitCode> {
    let listener = TcpListener::bind(a.listen)
        .await
        .with_context(|| format!("--listen {}", a.listen))?;
    let delays = Delays::new(a.seed);
    let control = {
        let delays = delays.clone();
        async move {
            let mut lines = BufReader::new(tokio::io::stdin()).lines();
            while let Some(line) = lines.next_line().await? {
                if let Err(e) = command(&line, &delays) {
                    // A bad line is the harness's bug; the proxy keeps what it had.
                    eprintln!("delay-proxy: '{line}': {e:#}");
                }
            }
            anyhow::Ok(())
        }
    };
    tokio::select! {
        r = serve(listener, a.upstream, delays) => r?,
        r = control => r?,
    }
    Ok(ExitCode::SUCCESS)
}

/// Accept connections on `listener` and forward each to `upstream`, delayed as `delays`
/// says for its peer.
pub async fn serve(
    listener: TcpListener,
    upstream: SocketAddr,
    delays: Delays,
) -> anyhow::Result<()> {
    loop {
        let (down, peer) = listener.accept().await.context("accepting")?;
        let delays = delays.clone();
        tokio::spawn(async move {
            let up = match TcpStream::connect(upstream).await {
                Ok(up) => up,
                Err(e) => {
                    eprintln!("delay-proxy: connecting {peer} to {upstream}: {e}");
                    return;
                }
            };
            let _ = down.set_nodelay(true);
            let _ = up.set_nodelay(true);
            let (down_r, down_w) = down.into_split();
            let (up_r, up_w) = up.into_split();
            let ip = peer.ip();
            // Either way failing ends both: the other side sees its connection close.
            let _ = tokio::try_join!(
                pipe(down_r, up_w, ip, delays.clone()),
                pipe(up_r, down_w, ip, delays),
            );
        });
    }
}

/// Copy `from` to `to`, each chunk held as `delays` says for `peer` when it was read.
async fn pipe(
    mut from: OwnedReadHalf,
    mut to: OwnedWriteHalf,
    peer: IpAddr,
    delays: Delays,
) -> std::io::Result<()> {
    let (tx, mut rx) = mpsc::unbounded_channel::<(Instant, Vec<u8>)>();
    let read = async move {
        let mut buf = vec![0; 64 * 1024];
        let mut last = Instant::now();
        loop {
            let n = from.read(&mut buf).await?;
            if n == 0 {
                return Ok(());
            }
            // Never before the chunk ahead of it: a stream does not reorder.
            let at = (Instant::now() + delays.hold(peer)).max(last);
            last = at;
            if tx.send((at, buf[..n].to_vec())).is_err() {
                return Ok(());
            }
        }
    };
    let write = async move {
        while let Some((at, bytes)) = rx.recv().await {
            tokio::time::sleep_until(at).await;
            to.write_all(&bytes).await?;
        }
        to.shutdown().await
    };
    tokio::try_join!(read, write).map(|_| ())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An upstream that echoes, and the proxy in front of it.
    async fn proxied(delays: Delays) -> SocketAddr {
        let echo = TcpListener::bind("127.0.0.1:0").await.unwrap();
        let upstream = echo.local_addr().unwrap();
        tokio::spawn(async move {
            while let Ok((s, _)) = echo.accept().await {
                tokio::spawn(async move {
                    let (mut r, mut w) = s.into_split();
                    let _ = tokio::io::copy(&mut r, &mut w).await;
                });
            }
        });
        let front = TcpListener::bind("127.0.0.1:0").await.unwrap();
        let addr = front.local_addr().unwrap();
        tokio::spawn(serve(front, upstream, delays));
        addr
    }

    #[tokio::test]
    async fn a_delayed_peers_bytes_come_back_in_order_and_no_sooner_than_the_delay_both_ways() {
        let delays = Delays::new(7);
        let addr = proxied(delays.clone()).await;
        let mut s = TcpStream::connect(addr).await.unwrap();
        // Not delayed yet: straight through.
        s.write_all(b"ping").await.unwrap();
        let mut got = [0u8; 4];
        s.read_exact(&mut got).await.unwrap();
        assert_eq!(&got, b"ping");

        command("delay 127.0.0.1 150 50", &delays).unwrap();
        let sent = Instant::now();
        let msg: Vec<u8> = (0..=255u8).cycle().take(100_000).collect();
        let (mut r, mut w) = s.into_split();
        let writer = tokio::spawn(async move {
            for chunk in msg.chunks(1000) {
                w.write_all(chunk).await.unwrap();
                tokio::time::sleep(Duration::from_millis(1)).await;
            }
            w
        });
        let mut back = vec![0u8; 100_000];
        r.read_exact(&mut back).await.unwrap();
        // Held once each way, at least the delay less the jitter each time.
        assert!(
            sent.elapsed() >= Duration::from_millis(200),
            "{:?}",
            sent.elapsed()
        );
        let want: Vec<u8> = (0..=255u8).cycle().take(100_000).collect();
        assert!(back == want, "bytes reordered or lost");
        drop(writer.await.unwrap());
    }

    #[test]
    fn a_bad_control_line_says_what_is_wrong_and_changes_nothing() {
        let delays = Delays::new(1);
        let peer: IpAddr = "10.0.0.2".parse().unwrap();
        for (line, why) in [
            ("delay 10.0.0.2 500", "expected"),
            ("delay nowhere 500 100", "peer 'nowhere'"),
            ("delay 10.0.0.2 fast 100", "delay 'fast'"),
            ("delay 10.0.0.2 100 500", "above the delay"),
        ] {
            let e = command(line, &delays).unwrap_err();
            assert!(format!("{e:#}").contains(why), "{line}: {e:#}");
        }
        assert_eq!(delays.hold(peer), Duration::ZERO);
        command("delay 10.0.0.2 500 0", &delays).unwrap();
        assert_eq!(delays.hold(peer), Duration::from_millis(500));
        command("clear", &delays).unwrap();
        assert_eq!(delays.hold(peer), Duration::ZERO);
    }
}
