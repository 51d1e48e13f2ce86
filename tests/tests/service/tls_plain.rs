//! A client that speaks plain text to a master's TLS port is told so in words: a gRPC client
//! (`hevo jobs --master http://...`) reads it in the connection's error, a browser or curl in a
//! 400, instead of "frame with invalid size".

use hevo_tests::service::{CLIENT_TOKEN, role_args};
use hevo_tests::{Scratch, hevo, start_master};
use std::io::{Read, Write};
use std::time::Duration;

#[test]
fn plain_text_on_the_tls_port_is_answered_in_words() {
    let scratch = Scratch::new("tls-plain");
    let certified = rcgen::generate_simple_self_signed(vec!["localhost".to_string()]).unwrap();
    let (cert, key) = (scratch.join("cert.pem"), scratch.join("key.pem"));
    std::fs::write(&cert, certified.cert.pem()).unwrap();
    std::fs::write(&key, certified.signing_key.serialize_pem()).unwrap();
    let mut args = role_args(&scratch);
    args.extend(
        [
            "--state-dir",
            &scratch.join("state").to_string_lossy(),
            "--tls-cert",
            &cert.to_string_lossy(),
            "--tls-key",
            &key.to_string_lossy(),
        ]
        .map(str::to_string),
    );
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let master = start_master(&args, &scratch.join("master.log"));
    let port = master.url.rsplit(':').next().unwrap().to_string();
    let plain = format!("http://127.0.0.1:{port}");

    let output = hevo(
        &["jobs", "--master", &plain],
        Some(CLIENT_TOKEN),
        Duration::from_secs(30),
    );
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success());
    assert!(
        stderr.contains("this port speaks TLS: connect with https://"),
        "{stderr}"
    );

    let mut stream = std::net::TcpStream::connect(format!("127.0.0.1:{port}")).unwrap();
    stream
        .set_read_timeout(Some(Duration::from_secs(10)))
        .unwrap();
    stream
        .write_all(b"GET / HTTP/1.1\r\nHost: x\r\n\r\n")
        .unwrap();
    let mut answer = String::new();
    let _ = stream.read_to_string(&mut answer);
    assert!(
        answer.starts_with("HTTP/1.1 400") && answer.contains("this port speaks TLS"),
        "{answer}"
    );

    // TLS clients are served as before.
    let output = hevo(
        &[
            "jobs",
            "--master",
            &master.url,
            "--tls-ca",
            &cert.to_string_lossy(),
        ],
        Some(CLIENT_TOKEN),
        Duration::from_secs(30),
    );
    assert!(output.status.success(), "{output:?}");
}
