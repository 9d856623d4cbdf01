//! A layer that turns tonic's OUT_OF_RANGE for an oversize message into the
//! RESOURCE_EXHAUSTED the proto documents.

use std::pin::Pin;

/// Answers a message above the size limit with RESOURCE_EXHAUSTED, the code the proto
/// documents (and the one an upload just above the limit gets from the service):
/// tonic's decoder refuses such messages before any handler runs, with OUT_OF_RANGE,
/// which no method of ours returns.
#[derive(Clone)]
pub struct OversizeExhausted<S>(pub(super) S);

impl<S: tonic::server::NamedService> tonic::server::NamedService for OversizeExhausted<S> {
    const NAME: &'static str = S::NAME;
}

impl<S, B, R> tower::Service<axum::http::Request<B>> for OversizeExhausted<S>
where
    S: tower::Service<axum::http::Request<B>, Response = axum::http::Response<R>>,
    S::Future: Send + 'static,
{
    type Response = axum::http::Response<R>;
    type Error = S::Error;
    type Future =
        Pin<Box<dyn std::future::Future<Output = Result<Self::Response, S::Error>> + Send>>;

    fn poll_ready(
        &mut self,
        cx: &mut std::task::Context<'_>,
    ) -> std::task::Poll<Result<(), Self::Error>> {
        self.0.poll_ready(cx)
    }

    fn call(&mut self, req: axum::http::Request<B>) -> Self::Future {
        let fut = self.0.call(req);
        Box::pin(async move {
            let mut resp = fut.await?;
            let out_of_range = (tonic::Code::OutOfRange as i32).to_string();
            let h = resp.headers_mut();
            if h.get("grpc-status")
                .is_some_and(|v| v.as_bytes() == out_of_range.as_bytes())
            {
                let code = (tonic::Code::ResourceExhausted as i32).to_string();
                h.insert(
                    "grpc-status",
                    code.parse().expect("a number is a header value"),
                );
            }
            Ok(resp)
        })
    }
}
