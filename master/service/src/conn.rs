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

/// The client preface every HTTP/2 (so every gRPC) connection opens with.
const HTTP2_PREFACE: &[u8] = b"PRI * HTTP/2.0\r\n\r\nSM\r\n\r\n";

/// How long a plain-text client has to finish the request it is refused on.
const REFUSAL_WAIT: std::time::Duration = std::time::Duration::from_secs(2);

/// Answers a client that spoke plain text to the TLS port with [`PLAIN_ON_TLS`], in its own
/// protocol, then closes the connection: a gRPC client gets its calls answered with status
/// FAILED_PRECONDITION and the sentence (not retried: the address is wrong, not the master
/// away), a browser or curl a 400.
pub async fn refuse_plain_text(stream: GuardedStream) {
    let _ = tokio::time::timeout(REFUSAL_WAIT, async {
        if speaks_http2(&stream).await {
            refuse_grpc(stream).await;
        } else {
            refuse_http1(stream).await;
        }
    })
    .await;
}

/// Whether the connection opens with the HTTP/2 preface; peeks (reads nothing) until enough
/// bytes arrived to tell.
async fn speaks_http2(stream: &GuardedStream) -> bool {
    let mut opening = [0u8; HTTP2_PREFACE.len()];
    loop {
        match stream.tcp().peek(&mut opening).await {
            Ok(0) | Err(_) => return false,
            Ok(n) if n == opening.len() || !HTTP2_PREFACE.starts_with(&opening[..n]) => {
                return opening[..n] == *HTTP2_PREFACE;
            }
            // A prefix of the preface so far: wait for the rest.
            Ok(_) => tokio::time::sleep(std::time::Duration::from_millis(5)).await,
        }
    }
}

/// Serves the connection as HTTP/2 and answers every call with a trailers-only gRPC status,
/// so the client reads the sentence as the call's error, whatever the order in which its
/// request and the connection's closing arrive.
async fn refuse_grpc(stream: GuardedStream) {
    let Ok(mut connection) = h2::server::handshake(stream).await else {
        return;
    };
    while let Some(Ok((_, mut respond))) = connection.accept().await {
        let refusal = http::Response::builder()
            .status(200)
            .header("content-type", "application/grpc")
            .header(
                "grpc-status",
                (tonic::Code::FailedPrecondition as i32).to_string(),
            )
            .header("grpc-message", PLAIN_ON_TLS)
            .body(())
            .expect("a fixed, valid response");
        let _ = respond.send_response(refusal, true);
        connection.graceful_shutdown();
    }
}

/// Reads the request (closing with unread bytes would reset the connection and lose the
/// answer) and answers a 400 that says why.
async fn refuse_http1(mut stream: GuardedStream) {
    use tokio::io::{AsyncReadExt, AsyncWriteExt};
    let mut request = [0u8; 4096];
    let _ = tokio::time::timeout(
        std::time::Duration::from_millis(200),
        stream.read(&mut request),
    )
    .await;
    let answer = format!(
        "HTTP/1.1 400 Bad Request\r\nContent-Type: text/plain\r\nContent-Length: {}\r\nConnection: close\r\n\r\n{PLAIN_ON_TLS}\n",
        PLAIN_ON_TLS.len() + 1
    );
    let _ = stream.write_all(answer.as_bytes()).await;
    let _ = stream.shutdown().await;
    // Let the client read it before the connection goes.
    while matches!(stream.read(&mut request).await, Ok(n) if n > 0) {}
}
