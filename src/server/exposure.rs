//! Who can reach a server: TLS identity, and the rule that a server listening beyond loopback
//! has both TLS and a bearer token unless its operator says `--insecure`.
use std::fmt;
use std::net::SocketAddr;

/// A TLS certificate chain and its private key, PEM-encoded.
#[derive(Clone, PartialEq, Eq)]
pub struct TlsIdentity {
    pub cert_pem: Vec<u8>,
    pub key_pem: Vec<u8>,
}

impl fmt::Debug for TlsIdentity {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "TlsIdentity({} bytes of certificates, key withheld)", self.cert_pem.len())
    }
}

/// Refuses to expose an unprotected server: an address other than loopback needs TLS and a
/// token, or an explicit `insecure`.
pub fn check_exposure(addr: SocketAddr, tls: bool, tokens: bool, insecure: bool) -> Result<(), String> {
    if addr.ip().is_loopback() || (tls && tokens) || insecure {
        return Ok(());
    }
    let missing = match (tls, tokens) {
        (false, false) => "TLS and a bearer token",
        (false, true) => "TLS",
        _ => "a bearer token",
    };
    Err(format!(
        "refusing to serve on {addr} without {missing}: anyone who can reach the address could use \
         the server. Give --tls-cert and --tls-key, and --token-file or WEDGE_TOKEN; or --insecure \
         if the network or a proxy in front provides them"
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn loopback_is_always_allowed_and_other_addresses_need_both() {
        let lo: SocketAddr = "127.0.0.1:50051".parse().unwrap();
        let lo6: SocketAddr = "[::1]:50051".parse().unwrap();
        let any: SocketAddr = "0.0.0.0:50051".parse().unwrap();
        assert!(check_exposure(lo, false, false, false).is_ok());
        assert!(check_exposure(lo6, false, false, false).is_ok());
        assert!(check_exposure(any, true, true, false).is_ok());
        assert!(check_exposure(any, false, false, true).is_ok());
        let e = check_exposure(any, false, false, false).unwrap_err();
        assert!(e.contains("without TLS and a bearer token") && e.contains("--insecure"), "{e}");
        assert!(check_exposure(any, true, false, false).unwrap_err().contains("without a bearer token"));
        assert!(check_exposure(any, false, true, false).unwrap_err().contains("without TLS:"));
    }
}
