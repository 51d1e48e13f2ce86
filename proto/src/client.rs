//! Connections to a master, shared by `hevo-worker` and the `hevo` client commands: the URL
//! (a bare `host:port` means plain `http://`), TLS when the URL is `https://` (the system's
//! web PKI roots, or the CA given with `--tls-ca` for a private certificate), the token on
//! every call, generous message limits, and HTTP/2 keep-alives so a dead master is noticed
//! even while a worker is busy evaluating. The command-line flags that say where the master is
//! (`MasterArgs`, with the feature `cli`) live here too, so `hevo-worker` and every `hevo` client command spell them,
//! their environment variables and their help the same way.

use crate::auth::ClientAuth;
use crate::v1::job_service_client::JobServiceClient;
use crate::v1::worker_service_client::WorkerServiceClient;
use std::path::PathBuf;
use std::time::Duration;
use tonic::service::interceptor::InterceptedService;
use tonic::transport::{Certificate, Channel, ClientTlsConfig, Endpoint};

/// Why a connection to a master could not be set up or made.
#[derive(Debug, thiserror::Error)]
pub enum ConnectError {
    /// The token cannot be used.
    #[error(transparent)]
    Token(#[from] crate::auth::TokenError),
    /// The URL does not parse.
    #[error("invalid master URL '{url}': {message}")]
    Url {
        /// As given.
        url: String,
        /// Why.
        message: String,
    },
    /// `--tls-ca` for a plain-text URL.
    #[error("--tls-ca was given but the master URL '{url}' is not https://")]
    CaWithoutTls {
        /// As given.
        url: String,
    },
    /// The CA certificate cannot be read.
    #[error("cannot read the CA certificate {path}: {cause}")]
    CaFile {
        /// The file.
        path: PathBuf,
        /// Why.
        /// Part of the message, not a `source()`, so `{:#}` prints it once.
        cause: std::io::Error,
    },
    /// TLS could not be configured.
    #[error("TLS setup failed: {0}")]
    Tls(String),
    /// The master did not answer.
    #[error("cannot connect to the master at {url}: {message}")]
    Unreachable {
        /// As given.
        url: String,
        /// Why, with its causes.
        message: String,
    },
}

/// Where and how to connect.
#[derive(Debug, Clone)]
pub struct ClientOptions {
    /// `http://host:port`, `https://host:port` or `host:port`.
    pub url: String,
    /// The token of the caller's role (a client's, or a worker's).
    pub token: Option<String>,
    /// A PEM CA certificate to trust for `https://` (instead of the web PKI roots).
    pub tls_ca: Option<PathBuf>,
}

/// How to reach a master, as command-line flags (flattened into `hevo-worker` and every `hevo`
/// client command).
#[cfg(feature = "cli")]
#[derive(Debug, Clone, clap::Args)]
pub struct MasterArgs {
    /// The master's URL: http://HOST:PORT, https://HOST:PORT, or HOST:PORT.
    // Without hiding, `--help` prints the variable's value, `[env: HEVO_MASTER=]` when unset.
    #[arg(long, env = "HEVO_MASTER", hide_env_values = true)]
    pub master: String,
    /// The token of this program's role: for `hevo` commands a client token, for `hevo-worker`
    /// a worker token (the master's --token-file or --worker-token-file).
    #[arg(long, env = "HEVO_TOKEN", hide_env_values = true)]
    pub token: Option<String>,
    /// Read the token from this file (wins over --token and HEVO_TOKEN).
    #[arg(long)]
    pub token_file: Option<PathBuf>,
    /// Trust this PEM CA certificate for an https:// master.
    #[arg(long)]
    pub tls_ca: Option<PathBuf>,
}

#[cfg(feature = "cli")]
impl MasterArgs {
    /// The connection options, with the token read from `--token-file` when one was given.
    pub fn options(&self) -> Result<ClientOptions, ConnectError> {
        let token = crate::auth::resolve_token(self.token.as_deref(), self.token_file.as_deref())?;
        Ok(ClientOptions {
            url: self.master.clone(),
            token,
            tls_ca: self.tls_ca.clone(),
        })
    }
}

/// A channel that carries the token.
pub type AuthChannel = InterceptedService<Channel, ClientAuth>;

/// The worker service client every hevo worker (real or fake) talks through.
pub type WorkerClient = WorkerServiceClient<AuthChannel>;

impl ClientOptions {
    /// The URL with a scheme.
    pub fn normalized_url(&self) -> String {
        if self.url.contains("://") {
            self.url.clone()
        } else {
            format!("http://{}", self.url)
        }
    }

    /// The endpoint, not yet connected.
    pub fn endpoint(&self) -> Result<Endpoint, ConnectError> {
        let url = self.normalized_url();
        let mut endpoint = Endpoint::from_shared(url.clone())
            .map_err(|e| ConnectError::Url {
                url: self.url.clone(),
                message: e.to_string(),
            })?
            .connect_timeout(Duration::from_secs(5))
            .tcp_nodelay(true)
            .http2_keep_alive_interval(Duration::from_secs(15))
            .keep_alive_timeout(Duration::from_secs(10))
            .keep_alive_while_idle(true);
        let https = url.starts_with("https://");
        if let Some(ca) = &self.tls_ca {
            if !https {
                return Err(ConnectError::CaWithoutTls {
                    url: self.url.clone(),
                });
            }
            let pem = std::fs::read(ca).map_err(|cause| ConnectError::CaFile {
                path: ca.clone(),
                cause,
            })?;
            let tls = ClientTlsConfig::new().ca_certificate(Certificate::from_pem(pem));
            endpoint = endpoint
                .tls_config(tls)
                .map_err(|e| ConnectError::Tls(e.to_string()))?;
        } else if https {
            endpoint = endpoint
                .tls_config(ClientTlsConfig::new().with_webpki_roots())
                .map_err(|e| ConnectError::Tls(e.to_string()))?;
        }
        Ok(endpoint)
    }

    /// A channel that connects on first use and reconnects by itself after the master comes
    /// back (calls fail with UNAVAILABLE meanwhile).
    pub fn lazy_channel(&self) -> Result<AuthChannel, ConnectError> {
        let channel = self.endpoint()?.connect_lazy();
        Ok(InterceptedService::new(
            channel,
            ClientAuth::new(self.token.as_deref())?,
        ))
    }

    /// A connected channel (fails fast when the master cannot be reached).
    pub async fn connect(&self) -> Result<AuthChannel, ConnectError> {
        let channel = self
            .endpoint()?
            .connect()
            .await
            .map_err(|e| ConnectError::Unreachable {
                url: self.url.clone(),
                message: error_chain(&e),
            })?;
        Ok(InterceptedService::new(
            channel,
            ClientAuth::new(self.token.as_deref())?,
        ))
    }
}

/// A job service client with hevo's message limits.
pub fn job_client(channel: AuthChannel) -> JobServiceClient<AuthChannel> {
    JobServiceClient::new(channel)
        .max_decoding_message_size(crate::MAX_MESSAGE_BYTES)
        .max_encoding_message_size(crate::MAX_MESSAGE_BYTES)
}

/// A worker service client with hevo's message limits.
pub fn worker_client(channel: AuthChannel) -> WorkerClient {
    WorkerServiceClient::new(channel)
        .max_decoding_message_size(crate::MAX_MESSAGE_BYTES)
        .max_encoding_message_size(crate::MAX_MESSAGE_BYTES)
}

/// An error and its sources on one line ("transport error: connection refused").
pub fn error_chain(error: &(dyn std::error::Error + 'static)) -> String {
    let mut text = error.to_string();
    let mut source = error.source();
    while let Some(cause) = source {
        let cause_text = cause.to_string();
        if !text.contains(&cause_text) {
            text.push_str(": ");
            text.push_str(&cause_text);
        }
        source = cause.source();
    }
    text
}

/// A status as a user-facing line: the code's name and the master's message.
pub fn describe_status(status: &tonic::Status) -> String {
    let code = code_name(status.code());
    if let Some(source) = std::error::Error::source(status) {
        return format!("{code}: {} ({})", status.message(), error_chain(source));
    }
    format!("{code}: {}", status.message())
}

/// A status code as the gRPC specification spells it (`PERMISSION_DENIED`), one style for every
/// code a message may show.
pub fn code_name(code: tonic::Code) -> &'static str {
    use tonic::Code;
    match code {
        Code::Ok => "OK",
        Code::Cancelled => "CANCELLED",
        Code::Unknown => "UNKNOWN",
        Code::InvalidArgument => "INVALID_ARGUMENT",
        Code::DeadlineExceeded => "DEADLINE_EXCEEDED",
        Code::NotFound => "NOT_FOUND",
        Code::AlreadyExists => "ALREADY_EXISTS",
        Code::PermissionDenied => "PERMISSION_DENIED",
        Code::ResourceExhausted => "RESOURCE_EXHAUSTED",
        Code::FailedPrecondition => "FAILED_PRECONDITION",
        Code::Aborted => "ABORTED",
        Code::OutOfRange => "OUT_OF_RANGE",
        Code::Unimplemented => "UNIMPLEMENTED",
        Code::Internal => "INTERNAL",
        Code::Unavailable => "UNAVAILABLE",
        Code::DataLoss => "DATA_LOSS",
        Code::Unauthenticated => "UNAUTHENTICATED",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_status_code_prints_in_the_specifications_style() {
        let denied = tonic::Status::permission_denied("a worker token cannot submit");
        assert_eq!(
            describe_status(&denied),
            "PERMISSION_DENIED: a worker token cannot submit"
        );
        for number in 0..=16 {
            let name = code_name(tonic::Code::from_i32(number));
            assert!(
                name.chars().all(|c| c.is_ascii_uppercase() || c == '_'),
                "{name}"
            );
        }
    }

    #[test]
    fn urls_get_a_scheme_and_tls_needs_https() {
        let options = ClientOptions {
            url: "127.0.0.1:5000".into(),
            token: None,
            tls_ca: None,
        };
        assert_eq!(options.normalized_url(), "http://127.0.0.1:5000");
        assert!(options.endpoint().is_ok());
        let tls = ClientOptions {
            tls_ca: Some("/nonexistent.pem".into()),
            ..options
        };
        assert!(matches!(
            tls.endpoint(),
            Err(ConnectError::CaWithoutTls { .. })
        ));
    }
}
