# Robot agent image. Build from the repository root:
#   docker build -f docker/agent.Dockerfile -t keyfleet-agent .
FROM debian:12 AS build
COPY scripts/install_deps.sh /src/scripts/install_deps.sh
RUN /src/scripts/install_deps.sh
COPY . /src
RUN cmake -S /src -B /build -G Ninja -DCMAKE_BUILD_TYPE=Release -DKEYFLEET_BUILD_TESTS=OFF \
 && cmake --build /build --target robot_agent

FROM debian:12
COPY scripts/install_deps.sh /opt/keyfleet/install_deps.sh
RUN /opt/keyfleet/install_deps.sh && rm -rf /var/lib/apt/lists/*
COPY --from=build /build/bin/robot_agent /usr/local/bin/robot_agent
COPY models/mininet/mininet_text.onnx models/mininet/mininet_text.json /usr/local/share/keyfleet/models/
COPY configs /opt/keyfleet/configs
COPY docker/configs /opt/keyfleet/docker-configs
WORKDIR /data
ENTRYPOINT ["robot_agent"]
CMD ["--config", "/opt/keyfleet/docker-configs/agent.yaml", "--run-dir", "/data"]
