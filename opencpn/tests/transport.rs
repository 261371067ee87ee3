//! The AIS outputs over real loopback sockets: UDP to every destination, the TCP server to every
//! client (bounded: a client past max_tcp_clients is refused and counted).

use std::sync::atomic::Ordering;
use std::time::Duration;

use frontseat_opencpn::transport::Outputs;
use tokio::io::AsyncBufReadExt;

const BOUND: Duration = Duration::from_secs(10);

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn udp_and_tcp_clients_get_every_sentence() {
    let a = tokio::net::UdpSocket::bind("127.0.0.1:0").await.unwrap();
    let b = tokio::net::UdpSocket::bind("127.0.0.1:0").await.unwrap();
    let udp = vec![
        a.local_addr().unwrap().to_string(),
        b.local_addr().unwrap().to_string(),
    ];
    let out = Outputs::open(&udp, "127.0.0.1:0", 1).await.unwrap();
    let tcp = out.tcp_addr().unwrap();
    let client = tokio::net::TcpStream::connect(tcp).await.unwrap();
    let mut lines = tokio::io::BufReader::new(client).lines();
    // The second client is over max_tcp_clients = 1: refused (its connection closed).
    let second = tokio::net::TcpStream::connect(tcp).await.unwrap();
    let t0 = tokio::time::Instant::now();
    while out.counters.tcp_refused.load(Ordering::Relaxed) == 0 {
        assert!(t0.elapsed() < BOUND, "the second client was not refused");
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    drop(second);
    let batch = vec![
        "!AIVDM,1,1,,A,B4M9Ph@03vfaHsV3kJ9DI3g40000,0*05\r\n".to_string(),
        "!AIVDM,1,1,,A,H4M9PhA@u1<T@F05=J3400000000,0*48\r\n".to_string(),
    ];
    // The client may be registered a moment after its connect returns: resend until it reads.
    let first = loop {
        assert!(t0.elapsed() < BOUND, "the TCP client got nothing");
        out.send(&batch);
        if let Ok(l) = tokio::time::timeout(Duration::from_millis(200), lines.next_line()).await {
            break l.unwrap().unwrap();
        }
    };
    assert_eq!(format!("{first}\r\n"), batch[0]);
    let second_line = tokio::time::timeout(BOUND, lines.next_line())
        .await
        .unwrap()
        .unwrap()
        .unwrap();
    assert_eq!(format!("{second_line}\r\n"), batch[1]);
    let mut buf = vec![0u8; 4096];
    for s in [&a, &b] {
        let n = tokio::time::timeout(BOUND, s.recv(&mut buf))
            .await
            .unwrap()
            .unwrap();
        assert_eq!(
            std::str::from_utf8(&buf[..n]).unwrap(),
            batch.concat(),
            "one datagram, both sentences"
        );
    }
    assert_eq!(out.counters.udp_errors.load(Ordering::Relaxed), 0);
}

#[tokio::test]
async fn a_bad_address_is_an_error_not_a_panic() {
    assert!(
        Outputs::open(&["not an address".into()], "", 1)
            .await
            .is_err()
    );
    assert!(Outputs::open(&[], "nowhere", 1).await.is_err());
}
