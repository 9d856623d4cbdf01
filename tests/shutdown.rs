//! Ctrl-C with event streams open: the streams end with a last event (SSE `shutdown`,
//! gRPC UNAVAILABLE), the server exits within a couple of seconds, and the running
//! job's checkpoint holds every iteration it rendered.

mod server_common;
use caustic::server::grpc::pb;
use pb::caustic_client::CausticClient;
use serde_json::{json, Value};
use server_common::{respond, tiny_scene, ServerProcess};
use std::io::{Read, Write};
use std::time::{Duration, Instant};

#[test]
fn ctrl_c_ends_streams_checkpoints_and_exits_promptly() {
    let dir = tempfile::tempdir().unwrap();
    let mut server = ServerProcess::start(dir.path(), &[]);
    let (url, grpc) = (server.url.clone(), server.grpc.clone());

    let (_, info) = respond(ureq::post(&format!("{url}/v1/scenes")).send_json(tiny_scene(64)));
    let scene = serde_json::from_slice::<Value>(&info).unwrap()["id"].clone();
    let (_, job) = respond(
        ureq::post(&format!("{url}/v1/jobs"))
            .send_json(json!({"scene": scene, "halt": {"spp": 10_000_000}})),
    );
    let id = serde_json::from_slice::<Value>(&job).unwrap()["id"]
        .as_str()
        .unwrap()
        .to_string();
    let job_url = format!("{url}/v1/jobs/{id}");
    let start = Instant::now();
    loop {
        let (_, b) = respond(ureq::get(&job_url).call());
        let j: Value = serde_json::from_slice(&b).unwrap();
        if j["iteration"].as_u64().unwrap() > 0 {
            break;
        }
        assert!(start.elapsed() < Duration::from_secs(60));
        std::thread::sleep(Duration::from_millis(20));
    }

    // An SSE stream, read raw so that its end is seen as it happens.
    let addr = url.trim_start_matches("http://").to_string();
    let sse_addr = addr.clone();
    let sse_id = id.clone();
    let sse = std::thread::spawn(move || {
        let mut s = std::net::TcpStream::connect(&sse_addr).unwrap();
        s.set_read_timeout(Some(Duration::from_secs(30))).unwrap();
        write!(
            s,
            "GET /v1/jobs/{sse_id}/events HTTP/1.1\r\nHost: {sse_addr}\r\n\r\n"
        )
        .unwrap();
        let mut text = Vec::new();
        let _ = s.read_to_end(&mut text);
        String::from_utf8_lossy(&text).into_owned()
    });
    // A gRPC WatchJob stream.
    let grpc_id = id.clone();
    let watch = std::thread::spawn(move || {
        let rt = tokio::runtime::Runtime::new().unwrap();
        rt.block_on(async move {
            let mut c = CausticClient::connect(format!("http://{grpc}"))
                .await
                .unwrap();
            let mut stream = c
                .watch_job(pb::WatchJobRequest {
                    id: grpc_id,
                    include_snapshots: false,
                })
                .await
                .unwrap()
                .into_inner();
            loop {
                match stream.message().await {
                    Ok(Some(_)) => continue,
                    Ok(None) => return None,
                    Err(status) => return Some(status.code()),
                }
            }
        })
    });
    std::thread::sleep(Duration::from_millis(500));

    let t = Instant::now();
    // SAFETY: signalling our own child process.
    unsafe { libc::kill(server.pid() as i32, libc::SIGINT) };
    let status = loop {
        if let Some(s) = server.child.try_wait().unwrap() {
            break s;
        }
        if t.elapsed() > Duration::from_secs(20) {
            server.kill();
            panic!("the server did not exit within 20 s of Ctrl-C");
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    let took = t.elapsed();
    eprintln!("exited {:.2} s after Ctrl-C ({status})", took.as_secs_f64());
    assert!(status.success(), "{status}");
    assert!(took < Duration::from_secs(5), "took {took:?}");

    let sse_text = sse.join().unwrap();
    assert!(sse_text.contains("event: shutdown"), "{sse_text}");
    assert_eq!(watch.join().unwrap(), Some(tonic::Code::Unavailable));

    // The checkpoint holds the iteration job.json reports: nothing rendered was lost.
    let jd = dir.path().join("jobs").join(&id);
    let stored: Value =
        serde_json::from_str(&std::fs::read_to_string(jd.join("job.json")).unwrap()).unwrap();
    let it = stored["iteration"].as_u64().unwrap();
    let ck = std::fs::read(jd.join("checkpoint.bin")).unwrap();
    let ck_it = u64::from_le_bytes(ck[16..24].try_into().unwrap());
    assert_eq!(ck_it, it, "checkpoint behind the job's status");
    assert!(it > 0);
}
