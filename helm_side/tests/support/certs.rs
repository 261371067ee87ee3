//! A fleet's certificates made at test time with rcgen (no openssl binary): a CA, a certificate
//! per name for 127.0.0.1/localhost usable as both server and client, and a second, unrelated CA.
//! Shared by the gateway's and the topside's TLS tests (`#[path]`-included).

#![allow(dead_code)]

use std::path::{Path, PathBuf};

use frontseat_config::ZenohTlsConfig;
use rcgen::{
    BasicConstraints, CertificateParams, DnType, ExtendedKeyUsagePurpose, IsCa, Issuer, KeyPair,
    KeyUsagePurpose,
};

/// A certificate authority: its PEM file and what signs with it.
pub struct Ca {
    pub cert: PathBuf,
    issuer: Issuer<'static, KeyPair>,
    dir: PathBuf,
}

/// A directory removed when dropped.
pub struct TempDir(pub PathBuf);

impl TempDir {
    pub fn new(tag: &str) -> Self {
        let dir = std::env::temp_dir().join(format!(
            "frontseat-tls-{tag}-{}-{:?}",
            std::process::id(),
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .unwrap()
                .as_nanos()
        ));
        std::fs::create_dir_all(&dir).unwrap();
        Self(dir)
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Writes `text` to `path`, readable by its owner only (as a key must be).
pub fn write_private(path: &Path, text: &str) {
    std::fs::write(path, text).unwrap();
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o600)).unwrap();
    }
}

impl Ca {
    /// A new CA named `name`, its certificate written into `dir`.
    pub fn new(dir: &Path, name: &str) -> Self {
        let mut params = CertificateParams::new(Vec::<String>::new()).unwrap();
        params.is_ca = IsCa::Ca(BasicConstraints::Unconstrained);
        params.distinguished_name.push(DnType::CommonName, name);
        params.key_usages = vec![KeyUsagePurpose::KeyCertSign, KeyUsagePurpose::CrlSign];
        let key = KeyPair::generate().unwrap();
        let cert = params.self_signed(&key).unwrap();
        let path = dir.join(format!("{name}.pem"));
        std::fs::write(&path, cert.pem()).unwrap();
        Self {
            cert: path,
            issuer: Issuer::new(params, key),
            dir: dir.to_path_buf(),
        }
    }

    /// A certificate with common name `cn` for 127.0.0.1 and localhost, for both ends of a
    /// link; returns (certificate, key) files.
    pub fn issue(&self, cn: &str) -> (PathBuf, PathBuf) {
        self.issue_for(cn, &["127.0.0.1", "localhost"])
    }

    /// A certificate with common name `cn` naming `hosts` (addresses or DNS names) as subject
    /// alternative names, for both ends of a link; returns (certificate, key) files.
    pub fn issue_for(&self, cn: &str, hosts: &[&str]) -> (PathBuf, PathBuf) {
        let mut params =
            CertificateParams::new(hosts.iter().map(|h| h.to_string()).collect::<Vec<_>>())
                .unwrap();
        params.distinguished_name.push(DnType::CommonName, cn);
        params.use_authority_key_identifier_extension = true;
        params.key_usages = vec![KeyUsagePurpose::DigitalSignature];
        params.extended_key_usages = vec![
            ExtendedKeyUsagePurpose::ServerAuth,
            ExtendedKeyUsagePurpose::ClientAuth,
        ];
        let key = KeyPair::generate().unwrap();
        let cert = params.signed_by(&key, &self.issuer).unwrap();
        let stem = self
            .cert
            .file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or("ca")
            .to_string();
        let cert_path = self.dir.join(format!("{stem}-{cn}.pem"));
        let key_path = self.dir.join(format!("{stem}-{cn}.key"));
        std::fs::write(&cert_path, cert.pem()).unwrap();
        write_private(&key_path, &key.serialize_pem());
        (cert_path, key_path)
    }

    /// `[…tls]` trusting this CA and presenting `cn`'s certificate, mutual TLS on.
    pub fn tls_for(&self, cn: &str) -> ZenohTlsConfig {
        self.tls_for_hosts(cn, &["127.0.0.1", "localhost"])
    }

    /// Like [`Ca::tls_for`], the certificate naming `hosts`.
    pub fn tls_for_hosts(&self, cn: &str, hosts: &[&str]) -> ZenohTlsConfig {
        let (cert, key) = self.issue_for(cn, hosts);
        ZenohTlsConfig {
            root_ca_certificate: Some(self.cert.display().to_string()),
            certificate: Some(cert.display().to_string()),
            private_key: Some(key.display().to_string()),
            ..Default::default()
        }
    }

    /// `[…tls]` trusting this CA but presenting no certificate (mutual TLS off).
    pub fn tls_without_certificate(&self) -> ZenohTlsConfig {
        ZenohTlsConfig {
            root_ca_certificate: Some(self.cert.display().to_string()),
            mutual: false,
            ..Default::default()
        }
    }
}

/// A free TCP port on loopback.
pub fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}
