//! TLS to the database as libpq's `sslmode` and `sslrootcert` ask (rustls with ring):
//!
//! | `sslmode` | encrypted | server certificate checked |
//! |---|---|---|
//! | `disable` | never | — |
//! | `allow`, `prefer` (default) | if the server offers TLS | only if a root certificate is there (as `verify-ca`) |
//! | `require` | always | only if a root certificate is there (as `verify-ca`) |
//! | `verify-ca` | always | signed by a root certificate |
//! | `verify-full` | always | signed by a root certificate and naming the host connected to |
//!
//! The root certificates are read from `sslrootcert` (PEM), else `PGSSLROOTCERT`, else
//! `~/.postgresql/root.crt` if it exists; `sslmode` falls back to `PGSSLMODE`. tokio-postgres
//! parses neither `verify-*` nor `sslrootcert`, so [`take_ssl_options`] takes them out of the
//! connection string before it does.

use postgres::config::SslMode;
use rustls::client::danger::{HandshakeSignatureValid, ServerCertVerified, ServerCertVerifier};
use rustls::client::WebPkiServerVerifier;
use rustls::crypto::{verify_tls12_signature, verify_tls13_signature, CryptoProvider};
use rustls::pki_types::pem::PemObject;
use rustls::pki_types::{CertificateDer, ServerName, UnixTime};
use rustls::{CertificateError, DigitallySignedStruct, RootCertStore, SignatureScheme};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use tokio_postgres_rustls::MakeRustlsConnect;

/// libpq's `sslmode` values.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// No TLS.
    Disable,
    /// TLS if the server offers it (libpq tries without first; savme tries TLS first).
    Allow,
    /// TLS if the server offers it.
    Prefer,
    /// TLS or no connection.
    Require,
    /// TLS, the server's certificate signed by a root certificate.
    VerifyCa,
    /// As `VerifyCa`, and the certificate names the host connected to.
    VerifyFull,
}

impl Mode {
    fn parse(s: &str) -> Option<Mode> {
        Some(match s {
            "disable" => Mode::Disable,
            "allow" => Mode::Allow,
            "prefer" => Mode::Prefer,
            "require" => Mode::Require,
            "verify-ca" => Mode::VerifyCa,
            "verify-full" => Mode::VerifyFull,
            _ => return None,
        })
    }

    /// The name libpq gives it.
    pub fn name(self) -> &'static str {
        match self {
            Mode::Disable => "disable",
            Mode::Allow => "allow",
            Mode::Prefer => "prefer",
            Mode::Require => "require",
            Mode::VerifyCa => "verify-ca",
            Mode::VerifyFull => "verify-full",
        }
    }

    /// What tokio-postgres does with the connector: try TLS, insist on it, or not use it.
    pub fn client_mode(self) -> SslMode {
        match self {
            Mode::Disable => SslMode::Disable,
            Mode::Allow | Mode::Prefer => SslMode::Prefer,
            Mode::Require | Mode::VerifyCa | Mode::VerifyFull => SslMode::Require,
        }
    }
}

/// The TLS options taken out of a connection string.
#[derive(Debug, Default, Clone, PartialEq, Eq)]
pub struct SslOptions {
    /// `sslmode`, as written.
    pub mode: Option<String>,
    /// `sslrootcert`, as written.
    pub root_cert: Option<String>,
}

/// Splits `sslmode` and `sslrootcert` out of a `postgresql://` URL or a `key=value` string:
/// the rest of the string (for tokio-postgres) and the two options. `None` if the string
/// cannot be read (tokio-postgres then says why).
///
/// ```
/// use savme_postgres::tls::take_ssl_options;
/// let (rest, o) = take_ssl_options("postgresql://u@h/db?sslmode=verify-full&connect_timeout=5").unwrap();
/// assert_eq!(rest, "postgresql://u@h/db?connect_timeout=5");
/// assert_eq!(o.mode.as_deref(), Some("verify-full"));
/// ```
pub fn take_ssl_options(s: &str) -> Option<(String, SslOptions)> {
    let mut o = SslOptions::default();
    let mut take = |key: &str, value: String| match key {
        "sslmode" => {
            o.mode = Some(value);
            true
        }
        "sslrootcert" => {
            o.root_cert = Some(value);
            true
        }
        _ => false,
    };
    let rest = if s.starts_with("postgresql://") || s.starts_with("postgres://") {
        let Some((base, query)) = s.split_once('?') else {
            return Some((s.to_string(), o));
        };
        let kept: Vec<&str> = query
            .split('&')
            .filter(|p| {
                let (k, v) = p.split_once('=').unwrap_or((p, ""));
                !take(k, percent_decode(v))
            })
            .collect();
        if kept.is_empty() {
            base.to_string()
        } else {
            format!("{base}?{}", kept.join("&"))
        }
    } else {
        let mut kept = Vec::new();
        for (k, v) in key_values(s)? {
            if !take(&k, v.clone()) {
                let quoted = v.replace('\\', "\\\\").replace('\'', "\\'");
                kept.push(format!("{k}='{quoted}'"));
            }
        }
        kept.join(" ")
    };
    Some((rest, o))
}

/// The pairs of a libpq `key=value` string (values bare or single-quoted, `\` escapes).
fn key_values(s: &str) -> Option<Vec<(String, String)>> {
    let mut pairs = Vec::new();
    let mut it = s.chars().peekable();
    loop {
        while it.next_if(|c| c.is_whitespace()).is_some() {}
        let mut key = String::new();
        while let Some(c) = it.next_if(|c| !c.is_whitespace() && *c != '=') {
            key.push(c);
        }
        if key.is_empty() {
            return it.peek().is_none().then_some(pairs);
        }
        while it.next_if(|c| c.is_whitespace()).is_some() {}
        it.next_if_eq(&'=')?;
        while it.next_if(|c| c.is_whitespace()).is_some() {}
        let quoted = it.next_if_eq(&'\'').is_some();
        let mut value = String::new();
        loop {
            match it.next() {
                Some('\'') if quoted => break,
                Some(c) if !quoted && c.is_whitespace() => break,
                Some('\\') => value.push(it.next()?),
                Some(c) => value.push(c),
                None if quoted => return None,
                None => break,
            }
        }
        pairs.push((key, value));
    }
}

/// `%XX` decoded (as the URL form of a connection string is).
fn percent_decode(s: &str) -> String {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        let hex = b
            .get(i + 1..i + 3)
            .and_then(|h| std::str::from_utf8(h).ok());
        match (b[i], hex.and_then(|h| u8::from_str_radix(h, 16).ok())) {
            (b'%', Some(byte)) => {
                out.push(byte);
                i += 3;
            }
            (c, _) => {
                out.push(c);
                i += 1;
            }
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// How savme connects: the mode, the root certificates used (if any) and the connector.
#[derive(Clone)]
pub struct Tls {
    /// The `sslmode`.
    pub mode: Mode,
    /// The file the root certificates came from.
    pub root_cert: Option<PathBuf>,
    /// The rustls connector (`None` for `disable`).
    pub connector: Option<MakeRustlsConnect>,
}

impl Tls {
    /// The TLS settings of `options` (falling back to `PGSSLMODE`, `PGSSLROOTCERT` and
    /// `~/.postgresql/root.crt`); the error names the option or file at fault.
    pub fn new(options: &SslOptions) -> Result<Tls, String> {
        let env = |k: &str| std::env::var(k).ok().filter(|v| !v.is_empty());
        let (mode_text, mode_from) = match (&options.mode, env("PGSSLMODE")) {
            (Some(m), _) => (m.clone(), "sslmode"),
            (None, Some(m)) => (m, "PGSSLMODE"),
            (None, None) => ("prefer".into(), "sslmode"),
        };
        let mode = Mode::parse(&mode_text).ok_or_else(|| {
            format!("{mode_from}={mode_text:?} is not one of disable, allow, prefer, require, verify-ca, verify-full")
        })?;
        if mode == Mode::Disable {
            return Ok(Tls {
                mode,
                root_cert: None,
                connector: None,
            });
        }
        let explicit = options
            .root_cert
            .clone()
            .or_else(|| env("PGSSLROOTCERT"))
            .map(PathBuf::from);
        let default = std::env::var_os("HOME")
            .map(|h| Path::new(&h).join(".postgresql/root.crt"))
            .filter(|p| p.is_file());
        let verify = matches!(mode, Mode::VerifyCa | Mode::VerifyFull);
        let root_cert = match (explicit, default) {
            (Some(p), _) => Some(p),
            (None, Some(p)) => Some(p),
            (None, None) if verify => {
                return Err(format!(
                    "sslmode={} needs the root certificate(s) the server's certificate is signed by: give sslrootcert=FILE (PEM) in the URL, or PGSSLROOTCERT, or put them in ~/.postgresql/root.crt",
                    mode.name()
                ))
            }
            (None, None) => None,
        };
        let provider = Arc::new(rustls::crypto::ring::default_provider());
        let verifier: Arc<dyn ServerCertVerifier> = match &root_cert {
            None => Arc::new(Unverified(provider.clone())),
            Some(path) => {
                let roots = read_roots(path)?;
                let webpki =
                    WebPkiServerVerifier::builder_with_provider(roots.into(), provider.clone())
                        .build()
                        .map_err(|e| format!("sslrootcert {}: {e}", path.display()))?;
                if mode == Mode::VerifyFull {
                    webpki
                } else {
                    Arc::new(AnyName(webpki))
                }
            }
        };
        let config = rustls::ClientConfig::builder_with_provider(provider)
            .with_safe_default_protocol_versions()
            .map_err(|e| format!("TLS: {e}"))?
            .dangerous()
            .with_custom_certificate_verifier(verifier)
            .with_no_client_auth();
        Ok(Tls {
            mode,
            root_cert,
            connector: Some(MakeRustlsConnect::new(config)),
        })
    }

    /// What a TLS failure message adds: the mode and the root certificates checked against.
    pub fn explain(&self) -> String {
        match &self.root_cert {
            Some(p) if self.mode == Mode::VerifyFull => format!(
                "sslmode=verify-full: the server's certificate must be signed by a certificate in {} and name the host connected to",
                p.display()
            ),
            Some(p) => format!(
                "sslmode={}: the server's certificate must be signed by a certificate in {}",
                self.mode.name(),
                p.display()
            ),
            None => format!("sslmode={}", self.mode.name()),
        }
    }
}

/// The PEM certificates of `path`.
fn read_roots(path: &Path) -> Result<RootCertStore, String> {
    let bad = |what: String| format!("sslrootcert {}: {what}", path.display());
    let bytes = std::fs::read(path).map_err(|e| bad(format!("cannot read it: {e}")))?;
    let mut roots = RootCertStore::empty();
    for cert in CertificateDer::pem_slice_iter(&bytes) {
        let cert = cert.map_err(|e| bad(format!("not a PEM certificate file: {e}")))?;
        roots
            .add(cert)
            .map_err(|e| bad(format!("a certificate cannot be used: {e}")))?;
    }
    if roots.is_empty() {
        return Err(bad("holds no PEM certificate".into()));
    }
    Ok(roots)
}

/// `verify-ca`: the chain must lead to a root certificate; the host name is not checked.
#[derive(Debug)]
struct AnyName(Arc<WebPkiServerVerifier>);

impl ServerCertVerifier for AnyName {
    fn verify_server_cert(
        &self,
        end_entity: &CertificateDer<'_>,
        intermediates: &[CertificateDer<'_>],
        server_name: &ServerName<'_>,
        ocsp_response: &[u8],
        now: UnixTime,
    ) -> Result<ServerCertVerified, rustls::Error> {
        // webpki checks the chain first, the name last: a name error means the chain is good.
        match self
            .0
            .verify_server_cert(end_entity, intermediates, server_name, ocsp_response, now)
        {
            Err(rustls::Error::InvalidCertificate(
                CertificateError::NotValidForName | CertificateError::NotValidForNameContext { .. },
            )) => Ok(ServerCertVerified::assertion()),
            other => other,
        }
    }

    fn verify_tls12_signature(
        &self,
        message: &[u8],
        cert: &CertificateDer<'_>,
        dss: &DigitallySignedStruct,
    ) -> Result<HandshakeSignatureValid, rustls::Error> {
        self.0.verify_tls12_signature(message, cert, dss)
    }

    fn verify_tls13_signature(
        &self,
        message: &[u8],
        cert: &CertificateDer<'_>,
        dss: &DigitallySignedStruct,
    ) -> Result<HandshakeSignatureValid, rustls::Error> {
        self.0.verify_tls13_signature(message, cert, dss)
    }

    fn supported_verify_schemes(&self) -> Vec<SignatureScheme> {
        self.0.supported_verify_schemes()
    }
}

/// `prefer`/`require` without a root certificate (as libpq): encrypted, the certificate not
/// checked; the handshake signatures still are.
#[derive(Debug)]
struct Unverified(Arc<CryptoProvider>);

impl ServerCertVerifier for Unverified {
    fn verify_server_cert(
        &self,
        _end_entity: &CertificateDer<'_>,
        _intermediates: &[CertificateDer<'_>],
        _server_name: &ServerName<'_>,
        _ocsp_response: &[u8],
        _now: UnixTime,
    ) -> Result<ServerCertVerified, rustls::Error> {
        Ok(ServerCertVerified::assertion())
    }

    fn verify_tls12_signature(
        &self,
        message: &[u8],
        cert: &CertificateDer<'_>,
        dss: &DigitallySignedStruct,
    ) -> Result<HandshakeSignatureValid, rustls::Error> {
        verify_tls12_signature(
            message,
            cert,
            dss,
            &self.0.signature_verification_algorithms,
        )
    }

    fn verify_tls13_signature(
        &self,
        message: &[u8],
        cert: &CertificateDer<'_>,
        dss: &DigitallySignedStruct,
    ) -> Result<HandshakeSignatureValid, rustls::Error> {
        verify_tls13_signature(
            message,
            cert,
            dss,
            &self.0.signature_verification_algorithms,
        )
    }

    fn supported_verify_schemes(&self) -> Vec<SignatureScheme> {
        self.0.signature_verification_algorithms.supported_schemes()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ssl_options_are_taken_out_of_urls_and_key_value_strings() {
        let (rest, o) =
            take_ssl_options("postgresql://u:p@h/d?sslmode=require&sslrootcert=%2Ftmp%2Fca.pem")
                .unwrap();
        assert_eq!(rest, "postgresql://u:p@h/d");
        assert_eq!(o.mode.as_deref(), Some("require"));
        assert_eq!(o.root_cert.as_deref(), Some("/tmp/ca.pem"));
        let (rest, o) =
            take_ssl_options("host=h password='a b\\'c' sslmode = verify-ca sslrootcert='/x y'")
                .unwrap();
        assert_eq!(rest, "host='h' password='a b\\'c'");
        assert_eq!(o.mode.as_deref(), Some("verify-ca"));
        assert_eq!(o.root_cert.as_deref(), Some("/x y"));
        assert_eq!(take_ssl_options("host='unterminated"), None);
    }

    #[test]
    fn verify_modes_need_a_root_certificate_and_bad_modes_are_named() {
        let o = |mode: &str, root: Option<&str>| SslOptions {
            mode: Some(mode.into()),
            root_cert: root.map(str::to_string),
        };
        let e = Tls::new(&o("verify-everything", None)).err().unwrap();
        assert!(
            e.contains("sslmode=\"verify-everything\" is not one of"),
            "{e}"
        );
        let e = Tls::new(&o("verify-ca", Some("/nonexistent/ca.pem")))
            .err()
            .unwrap();
        assert!(
            e.contains("sslrootcert /nonexistent/ca.pem: cannot read it"),
            "{e}"
        );
        assert!(Tls::new(&o("disable", None)).unwrap().connector.is_none());
        assert!(Tls::new(&o("require", None)).unwrap().connector.is_some());
    }
}
