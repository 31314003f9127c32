"""rospy without ROS: logging as rospy printed it, parameters, topics to nobody, services."""

from __future__ import annotations

import pytest

from kr210_sim.exercise import node
from kr210_sim.exercise.messages import CalculateIK, Float64


@pytest.fixture(autouse=True)
def fresh_node() -> None:
    node.set_serve(None)


def test_logging_formats_as_rospy(capsys: pytest.CaptureFixture[str]) -> None:
    node.loginfo("Received %s eef-poses from the plan", 15)
    node.logwarn("careful")
    node.logdebug("not shown")
    for _ in range(3):
        node.loginfo_once("once")
    out, err = capsys.readouterr()
    lines = out.splitlines()
    assert lines[0].startswith("[INFO] [") and lines[0].endswith(
        "]: Received 15 eef-poses from the plan"
    )
    assert sum("once" in line for line in lines) == 1
    assert err.startswith("[WARN] [") and "not shown" not in out + err


def test_parameters_and_names() -> None:
    node.init_node("IK_server")
    assert node.get_name() == "/IK_server"
    assert node.get_param("~debug", False) is False
    with pytest.raises(KeyError, match=r"/trajectory_sampler/debug"):
        node.get_param("/trajectory_sampler/debug")
    node.set_param("~rate", 10)
    assert node.get_param("/IK_server/rate") == 10 and node.has_param("~rate")
    assert node.myargv(["IK_server.py", "__name:=ik", "x"]) == ["IK_server.py", "x"]


def test_topics_go_nowhere_and_services_are_local() -> None:
    pub = node.Publisher("/kuka_arm/EE_error", Float64, queue_size=10)
    pub.publish(Float64(0.1))
    assert pub.get_num_connections() == 0
    heard = []
    node.Subscriber("/joint_states", Float64, heard.append)
    with pytest.raises(node.ROSException):
        node.wait_for_service("/gazebo/spawn")
    service = node.Service("calculate_ik", CalculateIK, lambda req: len(req.poses))
    node.wait_for_service("calculate_ik")
    assert node.ServiceProxy("calculate_ik", CalculateIK)(poses=[1, 2]) == 2
    assert node.services() == {"/calculate_ik": service}
    assert heard == []
    assert issubclass(node.ROSInterruptException, KeyboardInterrupt)


def test_spin_hands_over_once_to_the_serving_loop() -> None:
    served = []
    node.set_serve(lambda: served.append(1))
    node.spin()  # no service yet: returns
    assert served == []
    node.Service("calculate_ik", CalculateIK, lambda req: None)
    node.spin()
    assert not node.is_shutdown()
    node.sleep(0)
    assert served == [1]
