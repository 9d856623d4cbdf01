//! Bearer-token auth as a tonic interceptor over the shared check (`server::auth`).

use crate::server::auth::{Refused, Token};
use tonic::service::Interceptor;
use tonic::{Request, Status};

/// Checks `authorization: Bearer <token>` metadata when a token is configured.
#[derive(Clone)]
pub struct BearerAuth {
    token: Token,
}

impl BearerAuth {
    pub fn new(token: Option<String>) -> Self {
        BearerAuth {
            token: Token::new(token),
        }
    }
}

impl Interceptor for BearerAuth {
    fn call(&mut self, req: Request<()>) -> Result<Request<()>, Status> {
        let given = req
            .metadata()
            .get("authorization")
            .and_then(|v| v.to_str().ok());
        match self.token.check(given) {
            Ok(()) => Ok(req),
            Err(Refused::Wrong) => Err(Status::unauthenticated("wrong bearer token")),
            Err(Refused::Missing) => Err(Status::unauthenticated(
                "this server needs a token: send metadata \"authorization: Bearer <token>\"",
            )),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bearer_tokens_are_checked() {
        let req = |auth: Option<&str>| {
            let mut r = Request::new(());
            if let Some(a) = auth {
                r.metadata_mut().insert("authorization", a.parse().unwrap());
            }
            r
        };
        let mut open = BearerAuth::new(None);
        assert!(open.call(req(None)).is_ok());
        let mut auth = BearerAuth::new(Some("s3cret".into()));
        assert!(auth.call(req(Some("Bearer s3cret"))).is_ok());
        assert!(auth.call(req(Some("bearer s3cret"))).is_ok());
        for bad in [
            None,
            Some("Bearer nope"),
            Some("s3cret"),
            Some("Basic s3cret"),
        ] {
            assert_eq!(
                auth.call(req(bad)).unwrap_err().code(),
                tonic::Code::Unauthenticated
            );
        }
    }
}
