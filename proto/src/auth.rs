//! Credentials: every call to the job and worker services carries
//! `authorization: Bearer <token>`, attached by [`ClientAuth`] on workers and client commands
//! and checked by [`ServerAuth`] on the master. There are two roles with separate tokens:
//! *clients* (people and scripts: submit, watch, fetch, cancel) may use only the job service,
//! *workers* only the worker service. A missing or unknown token is `UNAUTHENTICATED`; the other
//! role's token is `PERMISSION_DENIED`. Each role accepts a set of tokens, so a token is rotated
//! by adding the new one, moving its users over, and removing the old one ([`TokenSet::replace`],
//! which the master calls on SIGHUP). Checks compare SHA-256 digests in constant time, so
//! neither a token's content nor its length leaks through timing.

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
    #[error("cannot read the token file {path}: {cause}")]
    File {
        /// The file.
        path: std::path::PathBuf,
        /// Why.
        /// Part of the message, not a `source()`, so `{:#}` prints it once.
        cause: std::io::Error,
    },
    /// Nothing but whitespace.
    #[error("the token is empty")]
    Empty,
    /// Not printable ASCII without spaces, so it cannot travel in a header.
    #[error("the token must be printable ASCII without spaces")]
    NotPrintable,
}

/// Every token of a token file: one per line; blank lines and `#` comments are skipped (a
/// master's file may list several during a rotation). Each must be non-empty printable ASCII.
pub fn read_token_file(path: &Path) -> Result<Vec<String>, TokenError> {
    let text = std::fs::read_to_string(path).map_err(|cause| TokenError::File {
        path: path.to_path_buf(),
        cause,
    })?;
    let tokens: Vec<String> = text
        .lines()
        .map(str::trim)
        .filter(|line| !line.is_empty() && !line.starts_with('#'))
        .map(str::to_string)
        .collect();
    if tokens.is_empty() {
        return Err(TokenError::Empty);
    }
    for token in &tokens {
        check_token(token)?;
    }
    Ok(tokens)
}

fn check_token(token: &str) -> Result<(), TokenError> {
    if token.is_empty() {
        return Err(TokenError::Empty);
    }
    if !token.chars().all(|c| c.is_ascii_graphic()) {
        return Err(TokenError::NotPrintable);
    }
    Ok(())
}

/// Picks the token from `--token-file` (which wins, being the more deliberate choice) or
/// `--token` / `HEVO_TOKEN`. Surrounding whitespace (a file's final newline) is dropped; an
/// empty token or one that cannot travel in a header is an error.
pub fn resolve_token(
    token: Option<&str>,
    token_file: Option<&Path>,
) -> Result<Option<String>, TokenError> {
    if let Some(path) = token_file {
        // A client's or worker's file holds its own token: the first one.
        return Ok(read_token_file(path)?.into_iter().next());
    }
    let Some(raw) = token else { return Ok(None) };
    let token = raw.trim();
    check_token(token)?;
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

/// The tokens one role accepts, as digests, replaceable while the master runs.
#[derive(Clone, Default)]
pub struct TokenSet {
    digests: std::sync::Arc<std::sync::RwLock<Vec<[u8; 32]>>>,
}

impl std::fmt::Debug for TokenSet {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TokenSet")
            .field("tokens", &self.read().len())
            .finish()
    }
}

impl TokenSet {
    /// Accepts these tokens.
    pub fn new(tokens: &[String]) -> TokenSet {
        let set = TokenSet::default();
        set.replace(tokens);
        set
    }

    /// Accepts these tokens from now on, and no others (a rotation).
    pub fn replace(&self, tokens: &[String]) {
        let digests = tokens.iter().map(|t| digest(t.as_bytes())).collect();
        *self
            .digests
            .write()
            .unwrap_or_else(|poisoned| poisoned.into_inner()) = digests;
    }

    fn read(&self) -> std::sync::RwLockReadGuard<'_, Vec<[u8; 32]>> {
        self.digests
            .read()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
    }

    /// Whether `presented`'s digest is one of the set's, compared in constant time with each.
    fn contains(&self, presented: &[u8; 32]) -> bool {
        self.read().iter().fold(false, |found, expected| {
            let difference = presented
                .iter()
                .zip(expected)
                .fold(0u8, |acc, (a, b)| acc | (a ^ b));
            found | (difference == 0)
        })
    }

    /// Whether `token` is one of the set's (the same constant-time comparison as a call's
    /// metadata gets; the dashboard checks its cookies and headers with it).
    pub fn accepts(&self, token: &str) -> bool {
        self.contains(&digest(token.as_bytes()))
    }

    /// Whether the set shares a token with `other`.
    pub fn overlaps(&self, other: &TokenSet) -> bool {
        self.read().iter().any(|digest| other.contains(digest))
    }
}

/// A master's credentials: the clients' tokens and the workers' tokens.
#[derive(Debug, Clone, Default)]
pub struct Roles {
    /// People and scripts: the job service.
    pub clients: TokenSet,
    /// Workers: the worker service.
    pub workers: TokenSet,
}

/// Which service a [`ServerAuth`] guards.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    /// The job service.
    Client,
    /// The worker service.
    Worker,
}

/// Refuses calls without a token of its role. `open()` accepts everything (the master's
/// `--insecure-no-token`).
#[derive(Clone)]
pub struct ServerAuth {
    guard: Option<(Role, Roles)>,
}

impl std::fmt::Debug for ServerAuth {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ServerAuth")
            .field("role", &self.guard.as_ref().map(|(role, _)| *role))
            .finish()
    }
}

fn digest(bytes: &[u8]) -> [u8; 32] {
    Sha256::digest(bytes).into()
}

impl ServerAuth {
    /// Requires a token of `role` from `roles`.
    pub fn for_role(role: Role, roles: &Roles) -> ServerAuth {
        ServerAuth {
            guard: Some((role, roles.clone())),
        }
    }

    /// Requires nothing.
    pub fn open() -> ServerAuth {
        ServerAuth { guard: None }
    }

    /// Whether the metadata carries a token of this role.
    pub fn check(&self, metadata: &tonic::metadata::MetadataMap) -> Result<(), Status> {
        let Some((role, roles)) = &self.guard else {
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
        let found = digest(presented);
        let (own, other) = match role {
            Role::Client => (&roles.clients, &roles.workers),
            Role::Worker => (&roles.workers, &roles.clients),
        };
        if !presented.is_empty() && own.contains(&found) {
            return Ok(());
        }
        if !presented.is_empty() && other.contains(&found) {
            return Err(Status::permission_denied(match role {
                Role::Client => {
                    "a worker token cannot use the job service (submit, watch, fetch, cancel): use a client token"
                }
                Role::Worker => {
                    "a client token cannot use the worker service (lease or return batches): use a worker token"
                }
            }));
        }
        Err(Status::unauthenticated("wrong token"))
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

    fn roles() -> Roles {
        Roles {
            clients: TokenSet::new(&["s3cret".to_string()]),
            workers: TokenSet::new(&["w0rker".to_string(), "w0rker-new".to_string()]),
        }
    }

    #[test]
    fn each_service_takes_its_roles_tokens_only() {
        let roles = roles();
        let jobs = ServerAuth::for_role(Role::Client, &roles);
        let workers = ServerAuth::for_role(Role::Worker, &roles);
        let client = |token: &str| ClientAuth::new(Some(token)).unwrap();
        assert!(call(&jobs, &client("s3cret")).is_ok());
        assert!(call(&workers, &client("w0rker")).is_ok());
        assert!(call(&workers, &client("w0rker-new")).is_ok());
        assert_eq!(
            call(&workers, &client("s3cret")).unwrap_err().code(),
            tonic::Code::PermissionDenied
        );
        assert_eq!(
            call(&jobs, &client("w0rker")).unwrap_err().code(),
            tonic::Code::PermissionDenied
        );
        for wrong in [client("s3cre"), client("s3cret2"), ClientAuth::default()] {
            for server in [&jobs, &workers] {
                assert_eq!(
                    call(server, &wrong).unwrap_err().code(),
                    tonic::Code::Unauthenticated
                );
            }
        }
        let mut bare = Request::new(());
        bare.metadata_mut()
            .insert(AUTHORIZATION, "s3cret".parse().unwrap());
        assert!(
            jobs.clone().call(bare).is_err(),
            "the Bearer prefix is required"
        );
        assert!(call(&ServerAuth::open(), &ClientAuth::default()).is_ok());
        assert!(!roles.clients.overlaps(&roles.workers));
    }

    #[test]
    fn a_rotation_replaces_the_accepted_tokens() {
        let roles = roles();
        let workers = ServerAuth::for_role(Role::Worker, &roles);
        let old = ClientAuth::new(Some("w0rker")).unwrap();
        roles.workers.replace(&["w0rker-new".to_string()]);
        assert_eq!(
            call(&workers, &old).unwrap_err().code(),
            tonic::Code::Unauthenticated
        );
        assert!(call(&workers, &ClientAuth::new(Some("w0rker-new")).unwrap()).is_ok());
    }

    #[test]
    fn a_token_file_may_list_several() {
        let dir = std::env::temp_dir().join(format!("hevo-auth-list-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("tokens");
        std::fs::write(&file, "# rotation under way\nnew-one\n\n  old-one  \n").unwrap();
        assert_eq!(read_token_file(&file).unwrap(), ["new-one", "old-one"]);
        assert_eq!(
            resolve_token(None, Some(&file)).unwrap().as_deref(),
            Some("new-one")
        );
        std::fs::write(&file, "# nothing\n\n").unwrap();
        assert!(matches!(read_token_file(&file), Err(TokenError::Empty)));
        std::fs::write(&file, "ok\nnot ok\n").unwrap();
        assert!(matches!(
            read_token_file(&file),
            Err(TokenError::NotPrintable)
        ));
        std::fs::remove_dir_all(&dir).unwrap();
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
