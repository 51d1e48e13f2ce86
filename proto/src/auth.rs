//! The shared token: every call to the job and worker services carries
//! `authorization: Bearer <token>`, checked by [`ServerAuth`] on the master and attached by
//! [`ClientAuth`] on workers and client commands. A missing or wrong token is
//! `UNAUTHENTICATED`. The check compares SHA-256 digests in constant time, so neither the
//! token's content nor its length leaks through timing.

use sha2::{Digest, Sha256};
use std::path::Path;
use tonic::metadata::{Ascii, MetadataValue};
use tonic::service::Interceptor;
use tonic::{Request, Status};

/// The metadata key carrying the token.
pub const AUTHORIZATION: &str = "authorization";

/// A token that cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum TokenError {
    /// The token file cannot be read.
    #[error("cannot read the token file {path}: {source}")]
    File {
        /// The file.
        path: std::path::PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// Nothing but whitespace.
    #[error("the token is empty")]
    Empty,
    /// Not printable ASCII without spaces, so it cannot travel in a header.
    #[error("the token must be printable ASCII without spaces")]
    NotPrintable,
}

/// Picks the token from `--token-file` (which wins, being the more deliberate choice) or
/// `--token` / `HEVO_TOKEN`. Surrounding whitespace (a file's final newline) is dropped; an
/// empty token or one that cannot travel in a header is an error.
pub fn resolve_token(
    token: Option<&str>,
    token_file: Option<&Path>,
) -> Result<Option<String>, TokenError> {
    let raw = match token_file {
        Some(path) => Some(
            std::fs::read_to_string(path).map_err(|source| TokenError::File {
                path: path.to_path_buf(),
                source,
            })?,
        ),
        None => token.map(str::to_string),
    };
    let Some(raw) = raw else { return Ok(None) };
    let token = raw.trim();
    if token.is_empty() {
        return Err(TokenError::Empty);
    }
    if !token.chars().all(|c| c.is_ascii_graphic()) {
        return Err(TokenError::NotPrintable);
    }
    Ok(Some(token.to_string()))
}

/// Adds the token to every outgoing call (nothing when there is none).
#[derive(Clone, Default)]
pub struct ClientAuth {
    header: Option<MetadataValue<Ascii>>,
}

impl std::fmt::Debug for ClientAuth {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ClientAuth")
            .field("token", &self.header.as_ref().map(|_| "<redacted>"))
            .finish()
    }
}

impl ClientAuth {
    /// Sends `token`, if any.
    pub fn new(token: Option<&str>) -> Result<ClientAuth, TokenError> {
        let header = match token {
            Some(token) => Some(
                format!("Bearer {token}")
                    .parse()
                    .map_err(|_| TokenError::NotPrintable)?,
            ),
            None => None,
        };
        Ok(ClientAuth { header })
    }
}

impl Interceptor for ClientAuth {
    fn call(&mut self, mut request: Request<()>) -> Result<Request<()>, Status> {
        if let Some(header) = &self.header {
            request.metadata_mut().insert(AUTHORIZATION, header.clone());
        }
        Ok(request)
    }
}

/// Refuses calls without the right token. `open()` accepts everything (the master's
/// `--insecure-no-token`).
#[derive(Clone)]
pub struct ServerAuth {
    digest: Option<[u8; 32]>,
}

impl std::fmt::Debug for ServerAuth {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ServerAuth")
            .field("required", &self.digest.is_some())
            .finish()
    }
}

fn digest(bytes: &[u8]) -> [u8; 32] {
    Sha256::digest(bytes).into()
}

impl ServerAuth {
    /// Requires `token`.
    pub fn new(token: &str) -> ServerAuth {
        ServerAuth {
            digest: Some(digest(token.as_bytes())),
        }
    }

    /// Requires nothing.
    pub fn open() -> ServerAuth {
        ServerAuth { digest: None }
    }

    /// Whether the metadata carries the token.
    pub fn check(&self, metadata: &tonic::metadata::MetadataMap) -> Result<(), Status> {
        let Some(expected) = &self.digest else {
            return Ok(());
        };
        let Some(value) = metadata.get(AUTHORIZATION) else {
            return Err(Status::unauthenticated(
                "missing token: send `authorization: Bearer <token>` (hevo: --token, --token-file or HEVO_TOKEN)",
            ));
        };
        let presented = value
            .as_bytes()
            .strip_prefix(b"Bearer ")
            .unwrap_or_default();
        // Constant time over fixed-length digests: the comparison does not stop at the first
        // differing byte.
        let found = digest(presented);
        let difference = found
            .iter()
            .zip(expected)
            .fold(0u8, |acc, (a, b)| acc | (a ^ b));
        if presented.is_empty() || difference != 0 {
            return Err(Status::unauthenticated("wrong token"));
        }
        Ok(())
    }
}

impl Interceptor for ServerAuth {
    fn call(&mut self, request: Request<()>) -> Result<Request<()>, Status> {
        self.check(request.metadata())?;
        Ok(request)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn call(server: &ServerAuth, client: &ClientAuth) -> Result<(), Status> {
        let request = client.clone().call(Request::new(()))?;
        server.clone().call(request).map(|_| ())
    }

    #[test]
    fn the_right_token_passes_and_others_are_unauthenticated() {
        let server = ServerAuth::new("s3cret");
        assert!(call(&server, &ClientAuth::new(Some("s3cret")).unwrap()).is_ok());
        for client in [
            ClientAuth::new(Some("s3cre")).unwrap(),
            ClientAuth::new(Some("s3cret2")).unwrap(),
            ClientAuth::default(),
        ] {
            assert_eq!(
                call(&server, &client).unwrap_err().code(),
                tonic::Code::Unauthenticated
            );
        }
        let mut bare = Request::new(());
        bare.metadata_mut()
            .insert(AUTHORIZATION, "s3cret".parse().unwrap());
        assert!(
            server.clone().call(bare).is_err(),
            "the Bearer prefix is required"
        );
        assert!(call(&ServerAuth::open(), &ClientAuth::default()).is_ok());
    }

    #[test]
    fn tokens_resolve_from_file_or_flag() {
        let dir = std::env::temp_dir().join(format!("hevo-auth-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("token");
        std::fs::write(&file, "from-file\n").unwrap();
        assert_eq!(
            resolve_token(Some("flag"), Some(&file)).unwrap().as_deref(),
            Some("from-file")
        );
        assert_eq!(
            resolve_token(Some(" flag "), None).unwrap().as_deref(),
            Some("flag")
        );
        assert_eq!(resolve_token(None, None).unwrap(), None);
        assert!(matches!(
            resolve_token(Some("  "), None),
            Err(TokenError::Empty)
        ));
        assert!(matches!(
            resolve_token(Some("a b"), None),
            Err(TokenError::NotPrintable)
        ));
        let missing = dir.join("missing");
        let error = resolve_token(None, Some(&missing)).unwrap_err();
        assert!(
            matches!(&error, TokenError::File { path, .. } if *path == missing),
            "{error}"
        );
        assert!(!format!("{:?}", ClientAuth::new(Some("flag")).unwrap()).contains("flag"));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
