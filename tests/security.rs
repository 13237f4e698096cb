//! Exposure: TLS with a certificate and key, bearer tokens on every call but health, and
//! reflection (v1 and v1alpha) that can be turned off.
mod common;

use common::*;
use tonic::transport::{Certificate, Channel, ClientTlsConfig, Endpoint};
use tonic::Code;
use tonic_health::pb::{health_check_response::ServingStatus, health_client::HealthClient, HealthCheckRequest};
use wedge::client::Target;
use wedge::server::auth::Tokens;
use wedge::server::exposure::TlsIdentity;
use wedge::server::ServerConfig;

const TOKEN: &str = "s3cret-token-for-tests-only";

/// A self-signed certificate for 127.0.0.1: the server's identity and the client's CA.
fn self_signed() -> (TlsIdentity, Vec<u8>) {
    let certified = rcgen::generate_simple_self_signed(vec!["127.0.0.1".to_string()]).expect("certificate");
    let cert_pem = certified.cert.pem().into_bytes();
    let identity =
        TlsIdentity { cert_pem: cert_pem.clone(), key_pem: certified.signing_key.serialize_pem().into_bytes() };
    (identity, cert_pem)
}

async fn secure_server() -> (TestServer, Vec<u8>) {
    let (identity, ca) = self_signed();
    let config = ServerConfig { tls: Some(identity), tokens: Tokens::parse(TOKEN).unwrap(), ..Default::default() };
    (TestServer::with_config(config).await, ca)
}

async fn tls_channel(server: &TestServer, ca: &[u8]) -> Channel {
    Endpoint::from_shared(format!("https://{}", server.addr))
        .unwrap()
        .tls_config(ClientTlsConfig::new().ca_certificate(Certificate::from_pem(ca)))
        .unwrap()
        .connect()
        .await
        .expect("TLS connection")
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn renders_need_tls_and_a_valid_token() {
    let (server, ca) = secure_server().await;
    let target = |token: Option<&str>| Target {
        addr: format!("https://{}", server.addr),
        ca_pem: Some(ca.clone()),
        token: token.map(str::to_string),
    };

    let mut ok = wedge::client::connect(&target(Some(TOKEN))).await.expect("connect");
    let mut stream = ok.render(cornell(8, 6, 2, 1)).await.expect("an authorised render").into_inner();
    let mut frames = 0;
    while let Some(u) = stream.message().await.expect("stream") {
        frames += usize::from(matches!(u.kind, Some(wedge::proto::render_update::Kind::FrameComplete(_))));
    }
    assert_eq!(frames, 2);

    for token in [None, Some("s3cret-token-for-tests-onlx"), Some("a-different-but-long-token")] {
        let mut client = wedge::client::connect(&target(token)).await.expect("connect");
        let err = client.render(cornell(8, 6, 1, 1)).await.expect_err("refused");
        assert_eq!(err.code(), Code::Unauthenticated, "token {token:?}: {err:?}");
        let err = client.list_scenes(wedge::proto::ListScenesRequest {}).await.expect_err("refused");
        assert_eq!(err.code(), Code::Unauthenticated);
    }
    assert_eq!(server.state.renders_started(), 1);

    // Health needs no token (orchestrators probe without credentials), but still TLS.
    let mut health = HealthClient::new(tls_channel(&server, &ca).await);
    let status = health.check(HealthCheckRequest { service: String::new() }).await.expect("health").into_inner();
    assert_eq!(status.status, ServingStatus::Serving as i32);
    let plain = wedge::client::connect(&Target::from(server.addr.to_string().as_str())).await;
    let refused = match plain {
        Err(_) => true,
        Ok(mut c) => c.list_scenes(wedge::proto::ListScenesRequest {}).await.is_err(),
    };
    assert!(refused, "a plaintext client must not get through to a TLS server");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn reflection_needs_the_token_too() {
    use tonic_reflection::pb::v1::{
        server_reflection_client::ServerReflectionClient, server_reflection_request::MessageRequest,
        ServerReflectionRequest,
    };
    let (server, ca) = secure_server().await;
    let mut reflection = ServerReflectionClient::new(tls_channel(&server, &ca).await);
    let request = ServerReflectionRequest {
        host: String::new(),
        message_request: Some(MessageRequest::ListServices(String::new())),
    };
    let err = reflection.server_reflection_info(tokio_stream::iter(vec![request])).await.expect_err("no token");
    assert_eq!(err.code(), Code::Unauthenticated);
}

/// Lists services with the v1alpha protocol, the one older stock clients speak.
async fn list_services_v1alpha(channel: Channel) -> Result<Vec<String>, tonic::Status> {
    use tonic_reflection::pb::v1alpha::{
        server_reflection_client::ServerReflectionClient, server_reflection_request::MessageRequest,
        server_reflection_response::MessageResponse, ServerReflectionRequest,
    };
    let request = ServerReflectionRequest {
        host: String::new(),
        message_request: Some(MessageRequest::ListServices(String::new())),
    };
    let mut responses = ServerReflectionClient::new(channel)
        .server_reflection_info(tokio_stream::iter(vec![request]))
        .await?
        .into_inner();
    let response = responses.message().await?.expect("a response");
    let Some(MessageResponse::ListServicesResponse(list)) = response.message_response else {
        panic!("unexpected reflection response {response:?}");
    };
    Ok(list.service.into_iter().map(|s| s.name).collect())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn reflection_v1alpha_is_served_and_can_be_turned_off() {
    let server = TestServer::start().await;
    let names = list_services_v1alpha(server.channel().await).await.expect("v1alpha reflection");
    assert!(names.iter().any(|n| n == "wedge.v1.Renderer"), "{names:?}");
    assert!(names.iter().any(|n| n == "grpc.health.v1.Health"), "{names:?}");

    let off = TestServer::with_config(ServerConfig { reflection: false, ..Default::default() }).await;
    let err = list_services_v1alpha(off.channel().await).await.expect_err("reflection is off");
    assert_eq!(err.code(), Code::Unimplemented);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_health_port_answers_probes_in_plaintext_and_nothing_else() {
    let (identity, _) = self_signed();
    let config = ServerConfig {
        tls: Some(identity),
        tokens: Tokens::parse(TOKEN).unwrap(),
        health_addr: Some("127.0.0.1:0".parse().unwrap()),
        ..Default::default()
    };
    let server = TestServer::with_config(config).await;
    let ok = wait_until(std::time::Duration::from_secs(30), || server.state.health_addr().is_some()).await;
    assert!(ok, "the health port is bound");
    let addr = server.state.health_addr().unwrap();
    let channel = Endpoint::from_shared(format!("http://{addr}")).unwrap().connect().await.expect("plaintext");
    let status = HealthClient::new(channel.clone())
        .check(HealthCheckRequest { service: "wedge.v1.Renderer".into() })
        .await
        .expect("a probe needs neither TLS nor a token")
        .into_inner();
    assert_eq!(status.status, ServingStatus::Serving as i32);
    let err = wedge::proto::renderer_client::RendererClient::new(channel)
        .render(cornell(8, 6, 1, 1))
        .await
        .expect_err("no renders on the health port");
    assert_eq!(err.code(), Code::Unimplemented);
}
