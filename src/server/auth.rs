//! The bearer-token check, one for both transports: the REST middleware
//! (`http::auth`) and the gRPC interceptor (`grpc::BearerAuth`) only read the
//! `authorization` value and map a refusal to their own answer.
//!
//! The value is `Bearer <token>`: the scheme in any case (RFC 7235 section 2.1, RFC
//! 6750 section 2.1), one or more spaces before the token (RFC 7235's `1*SP`), and the
//! token compared in constant time, so that timing does not reveal a matching prefix.
//! This module imports nothing of the server.

use std::sync::Arc;

/// The token a server requires, if any (an empty one is none).
#[derive(Clone, Debug, Default)]
pub struct Token(Option<Arc<str>>);

/// Why a request is refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Refused {
    /// No `Bearer` credentials at all (no header, another scheme, no token).
    Missing,
    /// A bearer token that is not the server's.
    Wrong,
}

impl Token {
    pub fn new(token: Option<String>) -> Token {
        Token(token.filter(|t| !t.is_empty()).map(Arc::from))
    }

    /// Whether a request whose `authorization` value is `authorization` may pass.
    pub fn check(&self, authorization: Option<&str>) -> Result<(), Refused> {
        let Some(expected) = &self.0 else {
            return Ok(());
        };
        match authorization.and_then(bearer) {
            Some(t) if same_secret(t.as_bytes(), expected.as_bytes()) => Ok(()),
            Some(_) => Err(Refused::Wrong),
            None => Err(Refused::Missing),
        }
    }
}

/// The token of a `Bearer` credential, if `value` is one.
fn bearer(value: &str) -> Option<&str> {
    let (scheme, token) = value.trim().split_once(' ')?;
    let token = token.trim_start_matches(' ');
    (scheme.eq_ignore_ascii_case("bearer") && !token.is_empty()).then_some(token)
}

/// Compares without an early exit, so timing does not reveal a matching prefix.
fn same_secret(a: &[u8], b: &[u8]) -> bool {
    a.len() == b.len() && a.iter().zip(b).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_scheme_is_case_insensitive_and_the_token_exact() {
        let t = Token::new(Some("s3cret".into()));
        for ok in [
            "Bearer s3cret",
            "bearer s3cret",
            "BEARER s3cret",
            "Bearer  s3cret",
            " Bearer s3cret ",
        ] {
            assert_eq!(t.check(Some(ok)), Ok(()), "{ok:?}");
        }
        for (bad, why) in [
            (None, Refused::Missing),
            (Some(""), Refused::Missing),
            (Some("s3cret"), Refused::Missing),
            (Some("Bearer"), Refused::Missing),
            (Some("Bearer "), Refused::Missing),
            (Some("Basic s3cret"), Refused::Missing),
            (Some("Bearers3cret"), Refused::Missing),
            (Some("Bearer S3CRET"), Refused::Wrong),
            (Some("Bearer s3cret2"), Refused::Wrong),
            (Some("Bearer s3cre"), Refused::Wrong),
            (Some("Bearer s3 cret"), Refused::Wrong),
        ] {
            assert_eq!(t.check(bad), Err(why), "{bad:?}");
        }
    }

    #[test]
    fn without_a_token_everything_passes() {
        for t in [Token::new(None), Token::new(Some(String::new()))] {
            assert_eq!(t.check(None), Ok(()));
            assert_eq!(t.check(Some("Basic x")), Ok(()));
        }
    }
}
