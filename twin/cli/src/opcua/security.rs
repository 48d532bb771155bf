//! OPC UA security of `twin serve` and of the machine link: the security mode (None, or
//! Basic256Sha256 Sign / SignAndEncrypt), the PKI folder as async-opcua lays it out, the user
//! and password, and the watch that turns async-opcua's refusal of a certificate into one line
//! naming the certificate's file.
//!
//! A PKI folder holds:
//!
//! - `own/cert.der` and `private/private.pem`: this application's certificate (self-signed,
//!   RSA 2048, valid 365 days) and private key, made on first use;
//! - `trusted/`: the peers' certificates (DER) this application trusts;
//! - `rejected/`: where a peer's certificate that is not trusted is put when it is refused;
//!   moving it into `trusted/` trusts it.
//!
//! async-opcua reports a refused certificate only through `tracing`; [`refusal_watch`] is a
//! `tracing` subscriber that sees only those events and hands over the certificate's file name.

use opcua::crypto::{CertificateStore, SecurityPolicy, X509Data};
use opcua::types::{ApplicationDescription, LocalizedText, MessageSecurityMode, UAString};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use thiserror::Error;
use tracing::field::{Field, Visit};
use tracing::metadata::LevelFilter;
use tracing::subscriber::Interest;
use tracing::{span, Dispatch, Event, Level, Metadata, Subscriber};

/// The environment variable a password is read from when no password file is given.
pub const PASSWORD_ENV: &str = "TWIN_OPCUA_PASSWORD";
/// The own certificate, under the PKI folder.
const OWN_CERTIFICATE: &str = "own/cert.der";
/// The own private key, under the PKI folder.
const OWN_PRIVATE_KEY: &str = "private/private.pem";

/// The security of an OPC UA connection.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum Security {
    /// Security policy None: no certificates, nothing signed or encrypted (loopback only).
    #[default]
    None,
    /// Basic256Sha256, messages signed.
    Sign,
    /// Basic256Sha256, messages signed and encrypted.
    #[value(name = "sign-encrypt")]
    SignAndEncrypt,
}

impl Security {
    /// True for Sign and SignAndEncrypt (certificates are exchanged).
    pub fn is_secure(self) -> bool {
        self != Security::None
    }

    /// The OPC UA security policy.
    pub fn policy(self) -> SecurityPolicy {
        match self {
            Security::None => SecurityPolicy::None,
            Security::Sign | Security::SignAndEncrypt => SecurityPolicy::Basic256Sha256,
        }
    }

    /// The OPC UA message security mode.
    pub fn mode(self) -> MessageSecurityMode {
        match self {
            Security::None => MessageSecurityMode::None,
            Security::Sign => MessageSecurityMode::Sign,
            Security::SignAndEncrypt => MessageSecurityMode::SignAndEncrypt,
        }
    }

    /// As the `--security` flag names it.
    pub fn flag(self) -> &'static str {
        match self {
            Security::None => "none",
            Security::Sign => "sign",
            Security::SignAndEncrypt => "sign-encrypt",
        }
    }
}

/// Why the security settings or the PKI folder could not be used; one line naming the file,
/// flag or variable and what to change.
#[derive(Debug, Error)]
pub enum SecurityError {
    /// The PKI folder or a file in it is unusable.
    #[error("--pki {}: {reason}", dir.display())]
    Pki {
        /// The PKI folder.
        dir: PathBuf,
        /// What is wrong and what to change.
        reason: String,
    },
    /// No PKI folder was given and there is no home folder to put the default one in.
    #[error("no --pki folder given and neither XDG_DATA_HOME nor HOME is set; give --pki DIR")]
    NoDefaultPki,
    /// The password file is unreadable or empty.
    #[error("--password-file {}: {reason}", path.display())]
    PasswordFile {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// A user without a password, or a password without a user.
    #[error("{0}")]
    Credentials(String),
}

/// The default PKI folder of `role` (`serve`, `shadow`): `$XDG_DATA_HOME/twin/pki/<role>`, or
/// `$HOME/.local/share/twin/pki/<role>`. Not a cache: the key and the trust in it must last.
pub fn default_pki(role: &str) -> Result<PathBuf, SecurityError> {
    let data = std::env::var_os("XDG_DATA_HOME")
        .filter(|d| !d.is_empty())
        .map(PathBuf::from)
        .or_else(|| {
            std::env::var_os("HOME")
                .filter(|h| !h.is_empty())
                .map(|h| PathBuf::from(h).join(".local/share"))
        })
        .ok_or(SecurityError::NoDefaultPki)?;
    Ok(data.join("twin").join("pki").join(role))
}

/// The password for `user`: the first line of `file`, or else [`PASSWORD_ENV`]; never from
/// the command line.
pub fn read_password(user: &str, file: Option<&Path>) -> Result<String, SecurityError> {
    let password = match file {
        Some(path) => {
            let bad = |reason: String| SecurityError::PasswordFile {
                path: path.to_path_buf(),
                reason,
            };
            // Only a regular file is opened: a FIFO would block the open.
            let metadata = std::fs::metadata(path).map_err(|e| bad(e.to_string()))?;
            if !metadata.is_file() {
                return Err(bad(
                    "not a regular file; give a file holding the password".into()
                ));
            }
            let text = std::fs::read_to_string(path).map_err(|e| bad(e.to_string()))?;
            let line = text.lines().next().unwrap_or("").to_string();
            if line.is_empty() {
                return Err(bad("empty; put the password on its first line".into()));
            }
            line
        }
        None => std::env::var(PASSWORD_ENV)
            .ok()
            .filter(|p| !p.is_empty())
            .ok_or_else(|| {
                SecurityError::Credentials(format!(
                    "--user {user}: no password; give --password-file FILE or set {PASSWORD_ENV}"
                ))
            })?,
    };
    Ok(password)
}

/// An application's PKI folder, its own certificate and key made.
#[derive(Debug, Clone)]
pub struct Pki {
    dir: PathBuf,
}

impl Pki {
    /// Opens `dir` (kept as an absolute path), making it, its `trusted/` and `rejected/` folders and the application's
    /// certificate (common name `name`, application URI `uri`, for this computer's names and
    /// addresses and `hosts`) and key if they are not there. The pair is written under
    /// temporary names and renamed into place, so that a failure leaves no half of it.
    pub fn open(dir: &Path, name: &str, uri: &str, hosts: &[String]) -> Result<Pki, SecurityError> {
        let bad = |reason: String| SecurityError::Pki {
            dir: dir.to_path_buf(),
            reason,
        };
        for sub in ["trusted", "rejected", "own", "private"] {
            std::fs::create_dir_all(dir.join(sub))
                .map_err(|e| bad(format!("cannot make {sub}/: {e}")))?;
        }
        restrict(&dir.join("private"), 0o700).map_err(|e| bad(format!("private/: {e}")))?;
        // Absolute, so that the lines naming its files can be followed from anywhere.
        let dir = std::fs::canonicalize(dir).map_err(|e| bad(e.to_string()))?;
        let pki = Pki { dir };
        let (cert, key) = (pki.own_certificate(), pki.private_key());
        match (cert.exists(), key.exists()) {
            (true, true) => {
                CertificateStore::read_cert(&cert).map_err(|e| {
                    bad(format!(
                        "{e}; remove {OWN_CERTIFICATE} and {OWN_PRIVATE_KEY} to make a new pair"
                    ))
                })?;
                Ok(pki)
            }
            (false, false) => {
                make_pair(&cert, &key, name, uri, hosts).map_err(bad)?;
                Ok(pki)
            }
            (has_cert, _) => {
                let (there, missing) = if has_cert {
                    (OWN_CERTIFICATE, OWN_PRIVATE_KEY)
                } else {
                    (OWN_PRIVATE_KEY, OWN_CERTIFICATE)
                };
                Err(bad(format!(
                    "{there} is there but {missing} is not; remove {there} to make a new pair"
                )))
            }
        }
    }

    /// The folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The application's certificate (DER), the one a peer must trust.
    pub fn own_certificate(&self) -> PathBuf {
        self.dir.join(OWN_CERTIFICATE)
    }

    /// The application's private key (PEM).
    pub fn private_key(&self) -> PathBuf {
        self.dir.join(OWN_PRIVATE_KEY)
    }

    /// Where the certificates of trusted peers go.
    pub fn trusted(&self) -> PathBuf {
        self.dir.join("trusted")
    }

    /// Where refused peers' certificates are put.
    pub fn rejected(&self) -> PathBuf {
        self.dir.join("rejected")
    }
}

/// Makes the certificate and key under temporary names, then renames the key and then the
/// certificate into place (a certificate is never there without its key).
fn make_pair(
    cert: &Path,
    key: &Path,
    name: &str,
    uri: &str,
    hosts: &[String],
) -> Result<(), String> {
    let tag = format!(".tmp-{}", std::process::id());
    let tmp_cert = cert.with_extension(format!("der{tag}"));
    let tmp_key = key.with_extension(format!("pem{tag}"));
    let description = ApplicationDescription {
        application_uri: UAString::from(uri),
        application_name: LocalizedText::new("", name),
        ..Default::default()
    };
    let data = X509Data::from((description, Some(hosts.to_vec())));
    let made = CertificateStore::create_certificate_and_key(&data, true, &tmp_cert, &tmp_key)
        .map_err(|e| format!("cannot make the certificate and key: {e}"))
        .and_then(|_| restrict(&tmp_key, 0o600).map_err(|e| format!("{}: {e}", tmp_key.display())))
        .and_then(|_| std::fs::rename(&tmp_key, key).map_err(|e| format!("{}: {e}", key.display())))
        .and_then(|_| {
            std::fs::rename(&tmp_cert, cert).map_err(|e| {
                let _ = std::fs::remove_file(key);
                format!("{}: {e}", cert.display())
            })
        });
    if made.is_err() {
        let _ = std::fs::remove_file(&tmp_cert);
        let _ = std::fs::remove_file(&tmp_key);
    }
    made
}

/// Sets a file's or folder's Unix permissions (nothing elsewhere).
fn restrict(path: &Path, mode: u32) -> std::io::Result<()> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(path, std::fs::Permissions::from_mode(mode))
    }
    #[cfg(not(unix))]
    {
        let _ = (path, mode);
        Ok(())
    }
}

/// A peer's certificate that async-opcua refused because it is not trusted.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Refusal {
    /// Its file name in the `rejected/` folder (`<common name> [<thumbprint>].der`).
    pub file_name: String,
    /// It was in `rejected/` already (refused before), rather than put there now.
    pub already_rejected: bool,
}

/// A `tracing` dispatch that sees only async-opcua's certificate-store warnings and calls
/// `on_refusal` for each certificate refused as untrusted. Set it as the default of the
/// threads that run the OPC UA stack (see [`on_runtime_threads`]).
pub fn refusal_watch(on_refusal: impl Fn(Refusal) + Send + Sync + 'static) -> Dispatch {
    Dispatch::new(RefusalWatch {
        on_refusal: Box::new(on_refusal),
    })
}

/// Makes `dispatch` the default on every thread of a tokio runtime being built.
pub fn on_runtime_threads(
    builder: &mut tokio::runtime::Builder,
    dispatch: Dispatch,
) -> &mut tokio::runtime::Builder {
    builder.on_thread_start(move || {
        // The guard would restore the previous default; these threads keep this one for life.
        std::mem::forget(tracing::dispatcher::set_default(&dispatch));
    })
}

/// See [`refusal_watch`].
struct RefusalWatch {
    on_refusal: Box<dyn Fn(Refusal) + Send + Sync>,
}

impl RefusalWatch {
    /// The certificate store's warnings (and errors) only.
    fn wanted(metadata: &Metadata<'_>) -> bool {
        metadata.is_event()
            && *metadata.level() <= Level::WARN
            && metadata
                .target()
                .starts_with("opcua_crypto::certificate_store")
    }
}

impl Subscriber for RefusalWatch {
    fn register_callsite(&self, metadata: &'static Metadata<'static>) -> Interest {
        if Self::wanted(metadata) {
            Interest::always()
        } else {
            Interest::never()
        }
    }

    fn enabled(&self, metadata: &Metadata<'_>) -> bool {
        Self::wanted(metadata)
    }

    fn max_level_hint(&self) -> Option<LevelFilter> {
        Some(LevelFilter::WARN)
    }

    fn new_span(&self, _span: &span::Attributes<'_>) -> span::Id {
        span::Id::from_u64(1)
    }

    fn record(&self, _span: &span::Id, _values: &span::Record<'_>) {}

    fn record_follows_from(&self, _span: &span::Id, _follows: &span::Id) {}

    fn event(&self, event: &Event<'_>) {
        let mut message = Message(String::new());
        event.record(&mut message);
        if let Some(refusal) = parse_refusal(&message.0) {
            (self.on_refusal)(refusal);
        }
    }

    fn enter(&self, _span: &span::Id) {}

    fn exit(&self, _span: &span::Id) {}
}

/// An event's `message` field as text.
struct Message(String);

impl Visit for Message {
    fn record_debug(&mut self, field: &Field, value: &dyn std::fmt::Debug) {
        if field.name() == "message" {
            let _ = write!(self.0, "{value:?}");
        }
    }

    fn record_str(&mut self, field: &Field, value: &str) {
        if field.name() == "message" {
            self.0.push_str(value);
        }
    }
}

/// async-opcua 0.19's two messages for an untrusted certificate (`certificate_store.rs`).
fn parse_refusal(message: &str) -> Option<Refusal> {
    let rest = message.strip_prefix("Certificate ")?;
    let (file_name, already_rejected) = if let Some(name) =
        rest.strip_suffix(" is unknown and untrusted so it will be stored in rejected directory")
    {
        (name, false)
    } else {
        let name =
            rest.strip_suffix(" is untrusted because it resides in the rejected directory")?;
        (name, true)
    };
    Some(Refusal {
        file_name: file_name.to_string(),
        already_rejected,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn both_refusal_messages_name_the_file() {
        let name = "twin client [0A1B].der";
        assert_eq!(
            parse_refusal(&format!(
                "Certificate {name} is unknown and untrusted so it will be stored in rejected directory"
            )),
            Some(Refusal {
                file_name: name.into(),
                already_rejected: false
            })
        );
        assert_eq!(
            parse_refusal(&format!(
                "Certificate {name} is untrusted because it resides in the rejected directory"
            ))
            .map(|r| r.already_rejected),
            Some(true)
        );
        assert_eq!(
            parse_refusal("Certificate x has an invalid key length"),
            None
        );
    }

    #[test]
    fn a_pki_folder_gets_one_pair_and_refuses_half_a_pair() {
        let dir = tempfile::tempdir().unwrap();
        let pki = Pki::open(dir.path(), "twin test", "urn:twin:test", &[]).unwrap();
        let cert = std::fs::read(pki.own_certificate()).unwrap();
        assert!(pki.trusted().is_dir() && pki.rejected().is_dir());
        let again = Pki::open(dir.path(), "twin test", "urn:twin:test", &[]).unwrap();
        assert_eq!(std::fs::read(again.own_certificate()).unwrap(), cert);
        std::fs::remove_file(pki.private_key()).unwrap();
        let message = Pki::open(dir.path(), "twin test", "urn:twin:test", &[])
            .unwrap_err()
            .to_string();
        assert!(
            message.contains("own/cert.der is there but private/private.pem is not"),
            "{message}"
        );
    }
}
