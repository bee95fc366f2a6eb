//! Who may see the viewer: anyone who can reach a loopback address, and on any other address only
//! a request carrying the token (`Authorization: Bearer TOKEN`, `?token=TOKEN`, or the cookie the
//! page gets when it was opened with `?token=`).

use crate::{Result, ViewerError};
use std::net::SocketAddr;

/// The cookie that carries the token after the page was opened with `?token=`.
pub const COOKIE: &str = "nomen_token";
/// The shortest token taken, in characters (16 hex digits are 64 bits).
pub const MIN_TOKEN_LEN: usize = 16;
/// The longest token taken, in characters.
pub const MAX_TOKEN_LEN: usize = 256;

/// The access policy of one server.
#[derive(Clone, PartialEq, Eq)]
pub enum Access {
    /// Every request is served (a loopback address without a token).
    Open,
    /// Requests must carry this token.
    Token(String),
}

impl std::fmt::Debug for Access {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        // The token is a secret: never in a log line.
        match self {
            Access::Open => f.write_str("Open"),
            Access::Token(_) => f.write_str("Token(..)"),
        }
    }
}

impl Access {
    /// The policy of a server bound to `listen`: a loopback address needs no token (one given is
    /// still asked for); any other address needs one. A token is 16 to 256 characters from
    /// `A-Z a-z 0-9 - . _ ~`, so that it travels unchanged in a URL and a cookie.
    pub fn for_listen(listen: SocketAddr, token: Option<&str>) -> Result<Access> {
        match token {
            Some(token) => {
                let is_safe = token
                    .bytes()
                    .all(|b| b.is_ascii_alphanumeric() || b"-._~".contains(&b));
                if !(MIN_TOKEN_LEN..=MAX_TOKEN_LEN).contains(&token.len()) || !is_safe {
                    return Err(ViewerError::Token(format!(
                        "the viewer's token must be {MIN_TOKEN_LEN} to {MAX_TOKEN_LEN} characters \
                         from A-Z a-z 0-9 - . _ ~ (e.g. `openssl rand -hex 16`)"
                    )));
                }
                Ok(Access::Token(token.to_owned()))
            }
            None if listen.ip().is_loopback() => Ok(Access::Open),
            None => Err(ViewerError::Token(format!(
                "the viewer listens on {listen}, not a loopback address: give it a token \
                 (--http-token or http_token), or listen on 127.0.0.1"
            ))),
        }
    }

    /// Whether a request with these parts may be served: the `Authorization` header, the query
    /// string and the `Cookie` header.
    pub fn allows(
        &self,
        authorization: Option<&str>,
        query: Option<&str>,
        cookie: Option<&str>,
    ) -> bool {
        match self {
            Access::Open => true,
            Access::Token(token) => {
                let bearer = authorization.and_then(|h| h.strip_prefix("Bearer "));
                bearer.is_some_and(|t| same(t, token))
                    || query_token(query).is_some_and(|t| same(t, token))
                    || cookie_token(cookie).is_some_and(|t| same(t, token))
            }
        }
    }
}

/// Whether a request's `Host` header names this machine's loopback (`localhost`, `127.0.0.1` or
/// `[::1]`, any port), or is absent. An open viewer (on loopback, without a token) answers only
/// such requests: a web page elsewhere that points its own host name at 127.0.0.1 (DNS
/// rebinding) would otherwise read the viewer through the operator's browser.
pub fn is_loopback_host(host: Option<&str>) -> bool {
    let Some(host) = host else {
        return true;
    };
    let name = match host.strip_prefix('[') {
        // `[::1]` or `[::1]:8080`.
        Some(rest) => rest.split(']').next().unwrap_or_default(),
        None => host.split(':').next().unwrap_or_default(),
    };
    name.eq_ignore_ascii_case("localhost") || name == "127.0.0.1" || name == "::1"
}

/// The `token` parameter of a query string.
pub fn query_token(query: Option<&str>) -> Option<&str> {
    query?
        .split('&')
        .find_map(|pair| pair.strip_prefix("token="))
}

/// The [`COOKIE`] of a `Cookie` header.
fn cookie_token(cookie: Option<&str>) -> Option<&str> {
    cookie?
        .split(';')
        .find_map(|c| c.trim().strip_prefix(COOKIE)?.strip_prefix('='))
}

/// Compares in time that depends on the lengths only, not on where the first difference is.
fn same(a: &str, b: &str) -> bool {
    a.len() == b.len()
        && a.bytes()
            .zip(b.bytes())
            .fold(0u8, |acc, (x, y)| acc | (x ^ y))
            == 0
}

#[cfg(test)]
mod tests {
    use super::*;

    const TOKEN: &str = "0123456789abcdef";

    fn addr(s: &str) -> SocketAddr {
        s.parse().unwrap()
    }

    #[test]
    fn only_loopback_host_names_are_loopback_hosts() {
        for host in [
            "localhost",
            "LOCALHOST:8080",
            "127.0.0.1",
            "127.0.0.1:8080",
            "[::1]:8080",
        ] {
            assert!(is_loopback_host(Some(host)), "{host}");
        }
        assert!(is_loopback_host(None));
        for host in [
            "evil.example",
            "evil.example:8080",
            "127.0.0.1.evil.example",
            "[::2]",
            "",
        ] {
            assert!(!is_loopback_host(Some(host)), "{host}");
        }
    }

    #[test]
    fn loopback_needs_no_token_and_any_other_address_needs_one() {
        assert_eq!(
            Access::for_listen(addr("127.0.0.1:8080"), None).unwrap(),
            Access::Open
        );
        assert_eq!(
            Access::for_listen(addr("[::1]:8080"), None).unwrap(),
            Access::Open
        );
        let e = Access::for_listen(addr("0.0.0.0:8080"), None).unwrap_err();
        assert!(e.to_string().contains("not a loopback address"), "{e}");
        assert!(Access::for_listen(addr("192.168.1.2:8080"), Some(TOKEN)).is_ok());
        // Too short, or characters a URL or a cookie would change.
        assert!(Access::for_listen(addr("0.0.0.0:8080"), Some("short")).is_err());
        assert!(Access::for_listen(addr("0.0.0.0:8080"), Some("0123456789abcdef;x")).is_err());
        assert_eq!(
            format!("{:?}", Access::Token(TOKEN.to_owned())),
            "Token(..)"
        );
    }

    #[test]
    fn the_token_is_taken_from_the_header_the_query_or_the_cookie() {
        let access = Access::Token(TOKEN.to_owned());
        assert!(!access.allows(None, None, None));
        assert!(access.allows(Some("Bearer 0123456789abcdef"), None, None));
        assert!(!access.allows(Some("Bearer 0123456789abcdeX"), None, None));
        assert!(!access.allows(Some("0123456789abcdef"), None, None));
        assert!(access.allows(None, Some("a=1&token=0123456789abcdef"), None));
        assert!(!access.allows(None, Some("token=0123456789abcde"), None));
        assert!(access.allows(None, None, Some("x=1; nomen_token=0123456789abcdef")));
        assert!(!access.allows(None, None, Some("nomen_tokenx=0123456789abcdef")));
        assert!(Access::Open.allows(None, None, None));
    }
}
