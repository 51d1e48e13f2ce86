//! Accepted connections that say when they close. A worker's leases belong to the connection
//! it leased them on: when that connection closes (the worker was killed, its machine rebooted,
//! the network dropped it and the HTTP/2 keep-alive gave up), nothing can come back on those
//! leases, so their batches are queued for other workers at once instead of after a whole
//! lease timeout. The stream wraps each accepted TCP connection; when hyper is done with it
//! and drops it, its peer address is sent to whoever listens.

use hevo_dashboard::connections::GuardedStream;
use std::net::SocketAddr;
use std::pin::Pin;
use std::task::{Context, Poll};
use tokio::io::{AsyncRead, AsyncWrite, ReadBuf};
use tokio::sync::mpsc;
use tonic::transport::server::{Connected, TcpConnectInfo};

/// A TCP connection that reports its peer on `closed` when it is dropped.
#[derive(Debug)]
pub struct TrackedStream {
    inner: GuardedStream,
    peer: Option<SocketAddr>,
    closed: mpsc::UnboundedSender<SocketAddr>,
}

impl TrackedStream {
    /// Wraps an accepted connection.
    pub fn new(inner: GuardedStream, closed: mpsc::UnboundedSender<SocketAddr>) -> TrackedStream {
        let peer = inner.tcp().peer_addr().ok();
        TrackedStream {
            inner,
            peer,
            closed,
        }
    }
}

impl Drop for TrackedStream {
    fn drop(&mut self) {
        if let Some(peer) = self.peer {
            let _ = self.closed.send(peer);
        }
    }
}

impl Connected for TrackedStream {
    type ConnectInfo = TcpConnectInfo;

    fn connect_info(&self) -> TcpConnectInfo {
        self.inner.tcp().connect_info()
    }
}

impl AsyncRead for TrackedStream {
    fn poll_read(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<std::io::Result<()>> {
        Pin::new(&mut self.inner).poll_read(cx, buf)
    }
}

impl AsyncWrite for TrackedStream {
    fn poll_write(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &[u8],
    ) -> Poll<std::io::Result<usize>> {
        Pin::new(&mut self.inner).poll_write(cx, buf)
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
        Pin::new(&mut self.inner).poll_write_vectored(cx, bufs)
    }

    fn is_write_vectored(&self) -> bool {
        self.inner.is_write_vectored()
    }
}

/// What a client that speaks plain HTTP or gRPC to the TLS port is told, instead of bytes it
/// cannot read ("frame with invalid size").
pub const PLAIN_ON_TLS: &str = "this port speaks TLS: connect with https://";

/// Whether a connection's first byte starts a TLS handshake (a TLS record of type 22); waits
/// for it at most `wait`. `None` when the client sent nothing in time or went away.
pub async fn starts_tls(stream: &GuardedStream, wait: std::time::Duration) -> Option<bool> {
    let mut first = [0u8; 1];
    match tokio::time::timeout(wait, stream.tcp().peek(&mut first)).await {
        Ok(Ok(1)) => Some(first[0] == 0x16),
        _ => None,
    }
}

/// Answers a client that spoke plain text to the TLS port with [`PLAIN_ON_TLS`], in its own
/// protocol (an HTTP/2 GOAWAY with the sentence as its debug data for gRPC, a 400 for HTTP/1),
/// then closes the connection.
pub async fn refuse_plain_text(mut stream: GuardedStream) {
    use tokio::io::{AsyncReadExt, AsyncWriteExt};
    let wait = std::time::Duration::from_millis(200);
    // Read what the client sent first: closing with unread bytes would reset the connection
    // and lose the answer.
    let mut request = [0u8; 4096];
    let read = tokio::time::timeout(wait, stream.read(&mut request))
        .await
        .ok()
        .and_then(Result::ok)
        .unwrap_or(0);
    let answer = if request[..read].starts_with(b"PRI * HTTP/2.0") {
        // The server's preface (an empty SETTINGS frame), then GOAWAY(PROTOCOL_ERROR).
        let debug = PLAIN_ON_TLS.as_bytes();
        let length = 8 + debug.len();
        let mut frames = vec![0, 0, 0, 0x4, 0, 0, 0, 0, 0];
        frames.extend_from_slice(&[
            (length >> 16) as u8,
            (length >> 8) as u8,
            length as u8,
            0x7,
            0,
            0,
            0,
            0,
            0,
        ]);
        frames.extend_from_slice(&[0, 0, 0, 0, 0, 0, 0, 1]);
        frames.extend_from_slice(debug);
        frames
    } else {
        format!(
            "HTTP/1.1 400 Bad Request\r\nContent-Type: text/plain\r\nContent-Length: {}\r\nConnection: close\r\n\r\n{PLAIN_ON_TLS}\n",
            PLAIN_ON_TLS.len() + 1
        )
        .into_bytes()
    };
    let _ = stream.write_all(&answer).await;
    let _ = stream.shutdown().await;
    // Let the client read it before the connection goes.
    let _ = tokio::time::timeout(std::time::Duration::from_secs(1), async {
        while matches!(stream.read(&mut request).await, Ok(n) if n > 0) {}
    })
    .await;
}
