"""Outlets over real iceoryx2 services: a fixed outlet's samples outlive its process's
publisher, and a batch larger than it was opened for is refused with the service named."""

import os
import sys
import uuid

import iceoryx2 as iox
import pytest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
import platoon.wire as w  # noqa: E402


@pytest.fixture
def run():
    """The services an orchestrator would create for a controller publishing inspections."""
    run_id = f"test-{uuid.uuid4().hex[:12]}"
    node = iox.NodeBuilder.new().create(iox.ServiceType.Ipc)
    wake = (
        node.service_builder(iox.ServiceName.new(w.wake_name(run_id, "controller")))
        .event()
        .create()
    )
    service = (
        node.service_builder(iox.ServiceName.new(w.service_name(run_id, "inspections")))
        .publish_subscribe(iox.Slice[w.Inspection])
        .user_header(w.StepHeader)
        .subscriber_max_buffer_size(8)
        .create()
    )
    yield run_id, service
    del wake, service, node


def received(subscriber):
    steps = []
    while (sample := subscriber.receive()) is not None:
        steps.append(w.StepHeader.from_address(sample.user_header_ptr).step)
    return steps


def test_a_fixed_outlets_samples_are_read_after_its_publisher_is_gone(run):
    run_id, service = run
    reader = service.subscriber_builder().buffer_size(8).create()
    controller = w.Endpoint("controller", run_id)
    out = controller.outlet("inspections", w.Inspection, 2, grow=False)
    reader.has_samples()  # connects, as the orchestrator does before the first step
    for k in range(3):
        out.send(k, k * 0.01, [w.Inspection(), w.Inspection()])
    # The process exits: its publisher goes before anybody read what it sent.
    out.publisher.delete()
    del out, controller
    assert received(reader) == [0, 1, 2]


def test_a_fixed_outlet_refuses_a_larger_batch_naming_its_service(run):
    run_id, _ = run
    controller = w.Endpoint("controller", run_id)
    out = controller.outlet("inspections", w.Inspection, 2, grow=False)
    with pytest.raises(ValueError, match="inspections sample of step 7 holds 3 items, more than the 2"):
        out.send(7, 0.07, [w.Inspection()] * 3)
