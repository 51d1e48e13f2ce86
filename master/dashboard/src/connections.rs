//! Connection limits for a listening port, shared by the master's gRPC port and the dashboard's
//! HTTP port: at most so many connections open at once (one more is closed as soon as it is
//! accepted), a connection that has not made a request within the first-request timeout closed
//! (an idle or trickling client, a TLS handshake never finished), and one idle for longer than
//! the idle timeout after its requests closed. Every limit hit is logged, at most once per
//! [`LOG_EVERY`] per port and kind, with how often it was hit since.
//!
//! What "made a request" means is the server's to say: the HTTP/1.1 dashboard answers only
//! requests, so its first byte written marks one; the gRPC port writes its HTTP/2 preface at
//! once, so its request layer marks the connection through [`GuardedStream::served`].

use std::collections::HashMap;
use std::net::SocketAddr;
use std::pin::Pin;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::task::{Context, Poll};
use std::time::Duration;
use tokio::io::{AsyncRead, AsyncWrite, ReadBuf};
use tokio::net::TcpStream;
use tokio::sync::{OwnedSemaphorePermit, Semaphore};
use tokio::time::{Instant, Sleep};

/// The most often a limit being hit is logged, per port and kind.
pub const LOG_EVERY: Duration = Duration::from_secs(10);

/// A port's limits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ConnectionLimits {
    /// Connections open at once.
    pub max_connections: usize,
    /// How long a connection may stay open without making a request.
    pub first_request_timeout: Duration,
    /// How long a connection that made a request may then stay without any traffic.
    pub idle_timeout: Duration,
}

impl ConnectionLimits {
    /// The defaults: 1,024 connections, 10 s to the first request, 120 s idle (the gRPC port
    /// pings every 20 s and the dashboard's event streams send a keep-alive every 15 s, so a
    /// live connection is never idle that long).
    pub const DEFAULT: ConnectionLimits = ConnectionLimits {
        max_connections: 1024,
        first_request_timeout: Duration::from_secs(10),
        idle_timeout: Duration::from_secs(120),
    };
}

/// Counts a limit's hits and logs them, at most once per [`LOG_EVERY`].
#[derive(Debug)]
struct HitLog {
    hits: AtomicU64,
    last_logged: Mutex<Option<Instant>>,
}

impl HitLog {
    fn new() -> HitLog {
        HitLog {
            hits: AtomicU64::new(0),
            last_logged: Mutex::new(None),
        }
    }

    /// Counts a hit; returns the hits since the last log line when one is due now.
    fn hit(&self) -> Option<u64> {
        self.hits.fetch_add(1, Ordering::Relaxed);
        let mut last = self
            .last_logged
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner());
        let now = Instant::now();
        if last.is_some_and(|at| now.duration_since(at) < LOG_EVERY) {
            return None;
        }
        *last = Some(now);
        Some(self.hits.swap(0, Ordering::Relaxed))
    }
}

/// A port's gate: admits accepted connections up to the limit and times them out.
#[derive(Debug)]
pub struct ConnectionGate {
    port: &'static str,
    limits: ConnectionLimits,
    permits: Arc<Semaphore>,
    refused: HitLog,
    timed_out: HitLog,
    /// The served flags of open connections by peer, for a request layer to mark.
    open: Mutex<HashMap<SocketAddr, Arc<AtomicBool>>>,
}

impl ConnectionGate {
    /// A gate for the port named `port` in log lines.
    pub fn new(port: &'static str, limits: ConnectionLimits) -> Arc<ConnectionGate> {
        Arc::new(ConnectionGate {
            port,
            limits,
            permits: Arc::new(Semaphore::new(limits.max_connections.max(1))),
            refused: HitLog::new(),
            timed_out: HitLog::new(),
            open: Mutex::new(HashMap::new()),
        })
    }

    /// The limits in force.
    pub fn limits(&self) -> ConnectionLimits {
        self.limits
    }

    /// Connections open now.
    pub fn open_connections(&self) -> usize {
        self.limits.max_connections.max(1) - self.permits.available_permits()
    }

    /// Admits an accepted connection, or closes it at once (dropping it) when the port is full.
    /// With `served_on_write`, the first byte the server writes marks it as having made a
    /// request.
    pub fn admit(
        self: &Arc<Self>,
        stream: TcpStream,
        served_on_write: bool,
    ) -> Option<GuardedStream> {
        let Ok(permit) = self.permits.clone().try_acquire_owned() else {
            if let Some(hits) = self.refused.hit() {
                tracing::warn!(
                    port = self.port,
                    refused = hits,
                    max_connections = self.limits.max_connections,
                    "connection limit reached: new connections are closed at once"
                );
            }
            return None;
        };
        let peer = stream.peer_addr().ok();
        let served = Arc::new(AtomicBool::new(false));
        if let Some(peer) = peer {
            self.lock_open().insert(peer, served.clone());
        }
        let now = Instant::now();
        Some(GuardedStream {
            inner: stream,
            _permit: permit,
            gate: self.clone(),
            peer,
            served,
            served_on_write,
            accepted: now,
            last_activity: now,
            timer: Box::pin(tokio::time::sleep_until(
                now + self.limits.first_request_timeout,
            )),
        })
    }

    /// Marks the open connection from `peer` as having made a request.
    pub fn mark_served(&self, peer: SocketAddr) {
        if let Some(flag) = self.lock_open().get(&peer) {
            flag.store(true, Ordering::Relaxed);
        }
    }

    fn lock_open(&self) -> std::sync::MutexGuard<'_, HashMap<SocketAddr, Arc<AtomicBool>>> {
        self.open
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
    }
}

/// An admitted connection: holds its place at the gate until dropped, and fails its next read
/// once it has timed out, which makes the server close it.
#[derive(Debug)]
pub struct GuardedStream {
    inner: TcpStream,
    _permit: OwnedSemaphorePermit,
    gate: Arc<ConnectionGate>,
    peer: Option<SocketAddr>,
    served: Arc<AtomicBool>,
    served_on_write: bool,
    accepted: Instant,
    last_activity: Instant,
    timer: Pin<Box<Sleep>>,
}

impl GuardedStream {
    /// The TCP connection.
    pub fn tcp(&self) -> &TcpStream {
        &self.inner
    }

    /// Whether it has made a request.
    pub fn served(&self) -> bool {
        self.served.load(Ordering::Relaxed)
    }

    /// When it times out as things stand.
    fn deadline(&self) -> Instant {
        let limits = self.gate.limits;
        if self.served() {
            self.last_activity + limits.idle_timeout
        } else {
            self.accepted + limits.first_request_timeout
        }
    }

    /// `Ready` with an error once the connection has timed out; else arms the timer.
    fn poll_timeout(&mut self, cx: &mut Context<'_>) -> Poll<std::io::Error> {
        loop {
            let deadline = self.deadline();
            if Instant::now() >= deadline {
                let served = self.served();
                if let Some(hits) = self.gate.timed_out.hit() {
                    tracing::warn!(
                        port = self.gate.port,
                        closed = hits,
                        "closed connections that made no request within {:?} or were idle for {:?}",
                        self.gate.limits.first_request_timeout,
                        self.gate.limits.idle_timeout
                    );
                }
                let what = if served {
                    "idle for too long"
                } else {
                    "no request in time"
                };
                return Poll::Ready(std::io::Error::new(std::io::ErrorKind::TimedOut, what));
            }
            if self.timer.deadline() != deadline {
                self.timer.as_mut().reset(deadline);
            }
            if self.timer.as_mut().poll(cx).is_pending() {
                return Poll::Pending;
            }
        }
    }
}

impl Drop for GuardedStream {
    fn drop(&mut self) {
        if let Some(peer) = self.peer {
            let mut open = self.gate.lock_open();
            if open
                .get(&peer)
                .is_some_and(|flag| Arc::ptr_eq(flag, &self.served))
            {
                open.remove(&peer);
            }
        }
    }
}

impl AsyncRead for GuardedStream {
    fn poll_read(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<std::io::Result<()>> {
        if let Poll::Ready(error) = self.poll_timeout(cx) {
            return Poll::Ready(Err(error));
        }
        let before = buf.filled().len();
        let polled = Pin::new(&mut self.inner).poll_read(cx, buf);
        if matches!(polled, Poll::Ready(Ok(()))) && buf.filled().len() > before {
            self.last_activity = Instant::now();
        }
        polled
    }
}

impl GuardedStream {
    fn wrote(&mut self, n: usize) {
        if n > 0 {
            self.last_activity = Instant::now();
            if self.served_on_write {
                self.served.store(true, Ordering::Relaxed);
            }
        }
    }
}

impl AsyncWrite for GuardedStream {
    fn poll_write(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &[u8],
    ) -> Poll<std::io::Result<usize>> {
        let polled = Pin::new(&mut self.inner).poll_write(cx, buf);
        if let Poll::Ready(Ok(n)) = polled {
            self.wrote(n);
        }
        polled
    }

    fn poll_flush(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<std::io::Result<()>> {
        Pin::new(&mut self.inner).poll_flush(cx)
    }

    fn poll_shutdown(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<std::io::Result<()>> {
        Pin::new(&mut self.inner).poll_shutdown(cx)
    }

    fn poll_write_vectored(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        bufs: &[std::io::IoSlice<'_>],
    ) -> Poll<std::io::Result<usize>> {
        let polled = Pin::new(&mut self.inner).poll_write_vectored(cx, bufs);
        if let Poll::Ready(Ok(n)) = polled {
            self.wrote(n);
        }
        polled
    }

    fn is_write_vectored(&self) -> bool {
        self.inner.is_write_vectored()
    }
}

/// A listener whose connections pass a gate: what the dashboard serves on.
#[derive(Debug)]
pub struct GatedListener {
    listener: tokio::net::TcpListener,
    gate: Arc<ConnectionGate>,
}

impl GatedListener {
    /// `listener` behind `gate`.
    pub fn new(listener: tokio::net::TcpListener, gate: Arc<ConnectionGate>) -> GatedListener {
        GatedListener { listener, gate }
    }
}

impl axum::serve::Listener for GatedListener {
    type Io = GuardedStream;
    type Addr = SocketAddr;

    async fn accept(&mut self) -> (Self::Io, Self::Addr) {
        loop {
            match self.listener.accept().await {
                Ok((stream, peer)) => {
                    if let Some(guarded) = self.gate.admit(stream, true) {
                        return (guarded, peer);
                    }
                }
                // Out of file descriptors or a connection reset before it was accepted: wait a
                // moment (as axum's own listener does) rather than spin.
                Err(error) => {
                    tracing::debug!(port = self.gate.port, %error, "accept failed");
                    tokio::time::sleep(Duration::from_millis(50)).await;
                }
            }
        }
    }

    fn local_addr(&self) -> std::io::Result<Self::Addr> {
        self.listener.local_addr()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tokio::io::{AsyncReadExt, AsyncWriteExt};

    fn limits(max_connections: usize) -> ConnectionLimits {
        ConnectionLimits {
            max_connections,
            first_request_timeout: Duration::from_millis(200),
            idle_timeout: Duration::from_millis(400),
        }
    }

    async fn pair(listener: &tokio::net::TcpListener) -> (TcpStream, TcpStream) {
        let client = TcpStream::connect(listener.local_addr().unwrap());
        let (client, accepted) = tokio::join!(client, listener.accept());
        (client.unwrap(), accepted.unwrap().0)
    }

    #[tokio::test]
    async fn the_gate_admits_up_to_its_limit_and_frees_a_place_on_close() {
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
        let gate = ConnectionGate::new("test", limits(2));
        let (_c1, s1) = pair(&listener).await;
        let (_c2, s2) = pair(&listener).await;
        let (_c3, s3) = pair(&listener).await;
        let first = gate.admit(s1, true).expect("first");
        let _second = gate.admit(s2, true).expect("second");
        assert!(gate.admit(s3, true).is_none(), "a third is over the limit");
        assert_eq!(gate.open_connections(), 2);
        drop(first);
        let (_c4, s4) = pair(&listener).await;
        assert!(
            gate.admit(s4, true).is_some(),
            "a closed one frees its place"
        );
    }

    #[tokio::test]
    async fn a_connection_without_a_request_times_out_and_one_that_made_one_lives_on() {
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
        let gate = ConnectionGate::new("test", limits(4));
        let (_silent_client, silent) = pair(&listener).await;
        let mut silent = gate.admit(silent, true).unwrap();
        let mut buf = [0u8; 8];
        let error = tokio::time::timeout(Duration::from_secs(5), silent.read(&mut buf))
            .await
            .expect("bounded")
            .unwrap_err();
        assert_eq!(error.kind(), std::io::ErrorKind::TimedOut);

        // A server that answered (wrote) keeps the connection while the client talks, then
        // closes it once it has been idle for the idle timeout.
        let (mut client, served) = pair(&listener).await;
        let mut served = gate.admit(served, true).unwrap();
        served.write_all(b"HTTP/1.1 200 OK\r\n").await.unwrap();
        for _ in 0..4 {
            tokio::time::sleep(Duration::from_millis(150)).await;
            client.write_all(b"x").await.unwrap();
            served.read_exact(&mut buf[..1]).await.unwrap();
        }
        let error = tokio::time::timeout(Duration::from_secs(5), served.read(&mut buf))
            .await
            .expect("bounded")
            .unwrap_err();
        assert_eq!(error.kind(), std::io::ErrorKind::TimedOut);
    }

    #[tokio::test]
    async fn a_request_layer_marks_a_connection_by_its_peer() {
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
        let gate = ConnectionGate::new("test", limits(4));
        let (client, accepted) = pair(&listener).await;
        let guarded = gate.admit(accepted, false).unwrap();
        assert!(!guarded.served());
        gate.mark_served(client.local_addr().unwrap());
        assert!(guarded.served());
        drop(guarded);
        assert!(gate.lock_open().is_empty());
    }
}
