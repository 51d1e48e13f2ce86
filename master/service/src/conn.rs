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
