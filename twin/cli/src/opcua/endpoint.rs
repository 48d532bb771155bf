//! The `--opcua` URL: `opc.tcp://HOST[:PORT]`, and whether it may be served: a loopback address
//! always, any other only with security (Sign or SignAndEncrypt) and a user.

use std::net::{IpAddr, Ipv4Addr, SocketAddr};
use thiserror::Error;

/// A URL that cannot be served; each is one line naming what to change.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum EndpointError {
    /// The URL is not `opc.tcp://HOST:PORT`.
    #[error("--opcua {url}: {reason}")]
    Malformed {
        /// The URL as given.
        url: String,
        /// What is wrong with it.
        reason: String,
    },
    /// The host is not a loopback address, and the server is not secured: security policy None
    /// and anonymous sessions are only served on loopback.
    #[error(
        "--opcua {url}: {host} is not a loopback address; serving beyond 127.0.0.1, ::1 or \
         localhost needs --security sign-encrypt (or sign) and --user NAME with its password \
         (--password-file FILE or TWIN_OPCUA_PASSWORD)"
    )]
    NotLoopback {
        /// The URL as given.
        url: String,
        /// Its host.
        host: String,
    },
}

/// OPC UA's registered port, used when the URL gives none.
const DEFAULT_PORT: u16 = 4840;

/// Where the server listens and the URL it advertises.
#[derive(Debug, Clone, PartialEq)]
pub struct Endpoint {
    /// The socket address bound.
    pub addr: SocketAddr,
    /// The host as the URL names it (advertised in the endpoint descriptions).
    pub host: String,
    /// The URL as given, for the endpoints and the messages.
    pub url: String,
}

/// Parses `opc.tcp://HOST[:PORT][/]`: HOST an IP literal (IPv6 in brackets) or `localhost`;
/// refuses any address that is not loopback.
pub fn parse(url: &str) -> Result<Endpoint, EndpointError> {
    let endpoint = parse_any(url)?;
    if !endpoint.addr.ip().is_loopback() {
        return Err(EndpointError::NotLoopback {
            url: url.to_string(),
            host: endpoint.host,
        });
    }
    Ok(endpoint)
}

/// Parses `opc.tcp://HOST[:PORT][/]` as [`parse`] does, and accepts a host beyond loopback only
/// when the server is `secure` (Sign or SignAndEncrypt) and asks for a user's password.
pub fn parse_served(url: &str, secure: bool, user: bool) -> Result<Endpoint, EndpointError> {
    if secure && user {
        parse_any(url)
    } else {
        parse(url)
    }
}

/// Parses `opc.tcp://HOST[:PORT][/]`, any address.
fn parse_any(url: &str) -> Result<Endpoint, EndpointError> {
    let bad = |reason: &str| EndpointError::Malformed {
        url: url.to_string(),
        reason: reason.to_string(),
    };
    let rest = url
        .strip_prefix("opc.tcp://")
        .ok_or_else(|| bad("must start with opc.tcp://"))?;
    let authority = rest.strip_suffix('/').unwrap_or(rest);
    if authority.contains('/') {
        return Err(bad("a path after the port is not supported"));
    }
    let (host, port) = split_port(authority).map_err(|reason| bad(&reason))?;
    let ip = if host.eq_ignore_ascii_case("localhost") {
        IpAddr::V4(Ipv4Addr::LOCALHOST)
    } else {
        host.parse::<IpAddr>()
            .map_err(|_| bad("the host must be an IP address or localhost"))?
    };
    Ok(Endpoint {
        addr: SocketAddr::new(ip, port),
        host: host.to_string(),
        url: url.to_string(),
    })
}

/// `HOST[:PORT]` or `[V6][:PORT]` into the host (without brackets) and the port.
fn split_port(authority: &str) -> Result<(&str, u16), String> {
    let (host, port) = if let Some(bracketed) = authority.strip_prefix('[') {
        let (host, after) = bracketed
            .split_once(']')
            .ok_or("an IPv6 host needs its closing ]")?;
        (host, after.strip_prefix(':'))
    } else {
        match authority.rsplit_once(':') {
            Some((host, port)) => (host, Some(port)),
            None => (authority, None),
        }
    };
    if host.is_empty() {
        return Err("no host".into());
    }
    let port = match port {
        None => DEFAULT_PORT,
        Some(port) => port
            .parse::<u16>()
            .map_err(|_| format!("port `{port}` is not a number from 0 to 65535"))?,
    };
    Ok((host, port))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn loopback_hosts_parse_with_their_ports() {
        let endpoint = parse("opc.tcp://127.0.0.1:4841").unwrap();
        assert_eq!(endpoint.addr, "127.0.0.1:4841".parse().unwrap());
        assert_eq!(parse("opc.tcp://localhost/").unwrap().addr.port(), 4840);
        assert_eq!(parse("opc.tcp://[::1]:5000").unwrap().addr.port(), 5000);
    }

    #[test]
    fn other_hosts_and_malformed_urls_are_refused() {
        for url in [
            "opc.tcp://0.0.0.0:4840",
            "opc.tcp://10.1.2.3:4840",
            "http://127.0.0.1:4840",
            "opc.tcp://127.0.0.1:99999",
            "opc.tcp://:4840",
            "opc.tcp://[::1:4840",
            "opc.tcp://127.0.0.1:4840/twin",
            "opc.tcp://machine.example:4840",
        ] {
            assert!(parse(url).is_err(), "{url}");
        }
    }

    #[test]
    fn beyond_loopback_needs_security_and_a_user() {
        let url = "opc.tcp://0.0.0.0:4840";
        for (secure, user) in [(false, false), (true, false), (false, true)] {
            assert!(matches!(
                parse_served(url, secure, user),
                Err(EndpointError::NotLoopback { .. })
            ));
        }
        assert_eq!(parse_served(url, true, true).unwrap().addr.port(), 4840);
        assert!(parse_served("opc.tcp://127.0.0.1:4840", false, false).is_ok());
    }
}
