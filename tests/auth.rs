//! One bearer-token rule for both transports: REST and gRPC servers started with the
//! same token accept and refuse the same `authorization` values (the scheme in any
//! case, one or more spaces before the token, the token exact).

mod server_common;
use caustic::job::{Service, ServiceConfig};
use caustic::server::grpc::{grpc_server, pb};
use pb::caustic_client::CausticClient;
use server_common::*;
use tokio_stream::wrappers::TcpListenerStream;

const TOKEN: &str = "s3cret";

/// `authorization` values and whether a server with [`TOKEN`] lets them through.
const CASES: &[(Option<&str>, bool)] = &[
    (Some("Bearer s3cret"), true),
    (Some("bearer s3cret"), true),
    (Some("BEARER s3cret"), true),
    (Some("Bearer  s3cret"), true),
    (None, false),
    (Some("s3cret"), false),
    (Some("Basic s3cret"), false),
    (Some("Bearer"), false),
    (Some("Bearers3cret"), false),
    (Some("Bearer wrong"), false),
    (Some("Bearer S3CRET"), false),
    (Some("Bearer s3cret2"), false),
];

/// Whether the REST server answers `GET /v1/jobs` with `authorization`.
fn http_passes(s: &TestServer, authorization: Option<&str>) -> bool {
    let mut req = ureq::get(&format!("{}/v1/jobs", s.url));
    if let Some(a) = authorization {
        req = req.set("authorization", a);
    }
    let (code, body) = respond(req.call());
    assert!(
        code == 200 || code == 401,
        "{authorization:?}: {code} {}",
        String::from_utf8_lossy(&body)
    );
    code == 200
}

/// A gRPC server with [`TOKEN`] on 127.0.0.1:0, on runtime `rt`; its address.
fn start_grpc(rt: &tokio::runtime::Runtime, svc: std::sync::Arc<Service>) -> String {
    let listener = rt
        .block_on(tokio::net::TcpListener::bind("127.0.0.1:0"))
        .unwrap();
    let addr = format!("http://{}", listener.local_addr().unwrap());
    let grpc = grpc_server(svc, Some(TOKEN.into()));
    rt.spawn(async move {
        tonic::transport::Server::builder()
            .add_service(grpc)
            .serve_with_incoming(TcpListenerStream::new(listener))
            .await
            .unwrap();
    });
    addr
}

/// Whether the gRPC server answers `ListScenes` with `authorization`.
async fn grpc_passes(addr: &str, authorization: Option<&str>) -> bool {
    let mut c = CausticClient::connect(addr.to_string()).await.unwrap();
    let mut req = tonic::Request::new(pb::ListScenesRequest {});
    if let Some(a) = authorization {
        req.metadata_mut()
            .insert("authorization", a.parse().unwrap());
    }
    match c.list_scenes(req).await {
        Ok(_) => true,
        Err(e) => {
            assert_eq!(e.code(), tonic::Code::Unauthenticated, "{authorization:?}");
            false
        }
    }
}

#[test]
fn rest_and_grpc_accept_and_refuse_the_same_headers() {
    let http = TestServer::start(Some(TOKEN));
    let dir = tempfile::tempdir().unwrap();
    let svc = Service::start(ServiceConfig::for_tests(dir.path())).unwrap();
    let rt = tokio::runtime::Runtime::new().unwrap();
    let grpc = start_grpc(&rt, svc.clone());
    for &(authorization, passes) in CASES {
        assert_eq!(
            http_passes(&http, authorization),
            passes,
            "REST {authorization:?}"
        );
        let by_grpc = rt.block_on(grpc_passes(&grpc, authorization));
        assert_eq!(by_grpc, passes, "gRPC {authorization:?}");
    }
    svc.shutdown();
}
