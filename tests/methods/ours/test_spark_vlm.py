"""The ``vlm`` prior against a real HTTP server on loopback speaking the chat-completions protocol."""

import json

import pytest
from helpers_http import LoopbackServer

from spark_bench.errors import InputError
from spark_bench.methods.ours.config import SparkConfig, VLMConfig
from spark_bench.methods.ours.vlm import request_structure

GOOD = {"links": [{"name": "body", "label": "body"}, {"name": "door", "label": "door"},
                  {"name": "drawer", "label": "drawer"}],
        "joints": [{"name": "joint_0", "type": "revolute", "parent": "body", "child": "door", "axis": "down",
                    "origin": [-0.6, 0.45, 0.4], "range": "large"},
                   {"name": "joint_1", "type": "prismatic", "parent": "body", "child": "drawer", "axis": "front",
                    "origin": [0.0, -0.5, 0.47], "range": "large"}]}


def _chat_answer(body: dict, entry: tuple) -> tuple[int, bytes, float]:
    status, content = entry
    payload = {"id": "x", "object": "chat.completion", "model": body["model"],
               "choices": [{"index": 0, "finish_reason": "stop", "message": {"role": "assistant", "content": content}}]}
    return status, json.dumps(payload).encode() if status == 200 else b'{"error": "boom"}', 0.0


class FakeVLM(LoopbackServer):
    """Serves a scripted list of (status, content) replies, then repeats the last; records requests."""

    def __init__(self, script):
        super().__init__(script, _chat_answer)

    @property
    def base_url(self):
        return f"{self.root}/v1"


def _config(url, **kw):
    return VLMConfig(base_url=url, model="test-vlm", api_key_env="SPARK_TEST_KEY", backoff_s=0.0, **kw)


def test_valid_answer_and_request_shape(monkeypatch):
    monkeypatch.setenv("SPARK_TEST_KEY", "sekrit")
    with FakeVLM([(200, json.dumps(GOOD))]) as vlm:
        structure, raw = request_structure(_config(vlm.base_url), b"\x89PNG fake", ["body", "door", "drawer"])
    assert [j.axis for j in structure.joints] == ["down", "front"] and structure.source == "vlm"
    assert structure.joint("joint_0").upper == pytest.approx(1.5707963, abs=1e-6)
    request = vlm.requests[0]
    assert request["path"] == "/v1/chat/completions" and request["auth"] == "Bearer sekrit"
    content = request["body"]["messages"][1]["content"]
    assert content[1]["image_url"]["url"].startswith("data:image/png;base64,")
    assert "clockwise" in content[0]["text"] and "door (part)" in content[0]["text"]
    schema = request["body"]["response_format"]["json_schema"]["schema"]
    assert schema["properties"]["joints"]["items"]["properties"]["axis"]["enum"][0] == "front"


def test_server_error_then_malformed_then_success():
    script = [(500, ""), (200, "not json at all"), (200, "```json\n" + json.dumps(GOOD) + "\n```")]
    with FakeVLM(script) as vlm:
        structure, _ = request_structure(_config(vlm.base_url, max_retries=3), b"png")
    assert len(vlm.requests) == 3 and len(structure.joints) == 2


def test_answer_that_does_not_fit_gives_one_line_error():
    bad = json.loads(json.dumps(GOOD))
    bad["joints"][0]["axis"] = "diagonal"
    with FakeVLM([(200, json.dumps(bad))]) as vlm:
        with pytest.raises(InputError) as info:
            request_structure(_config(vlm.base_url, max_retries=1), b"png")
    message = str(info.value)
    assert "\n" not in message and "diagonal" in message and "2 attempts" in message
    assert len(vlm.requests) == 2


def test_unknown_link_names_are_rejected():
    with FakeVLM([(200, json.dumps(GOOD))]) as vlm:
        with pytest.raises(InputError, match="unknown link names"):
            request_structure(_config(vlm.base_url, max_retries=0), b"png", ["body", "door"])


def test_answer_missing_a_known_part_is_asked_again():
    partial = json.loads(json.dumps(GOOD))
    partial["links"].pop()
    partial["joints"].pop()
    with FakeVLM([(200, json.dumps(partial)), (200, json.dumps(GOOD))]) as vlm:
        structure, _ = request_structure(_config(vlm.base_url, max_retries=1), b"png", ["body", "door", "drawer"])
    assert len(vlm.requests) == 2 and [link.name for link in structure.links] == ["body", "door", "drawer"]
    with FakeVLM([(200, json.dumps(partial))]) as vlm:
        with pytest.raises(InputError, match=r"missing link names \['drawer'\]"):
            request_structure(_config(vlm.base_url, max_retries=0), b"png", ["body", "door", "drawer"])


def test_run_ours_with_vlm_backend_from_config_file(tmp_path):
    from helpers_toy import write_toy_case

    from spark_bench.methods.ours import run_ours
    from spark_bench.methods.ours.method import ours_case

    case = tmp_path / "case"
    write_toy_case(case)
    with FakeVLM([(200, json.dumps(GOOD))]) as vlm:
        config_path = tmp_path / "ours.toml"
        config_path.write_text(f'[prior]\nbackend = "vlm"\n[vlm]\nbase_url = "{vlm.base_url}"\n'
                               f'model = "test-vlm"\nbackoff_s = 0.0\n[optimize]\nenabled = false\n')
        config = SparkConfig.from_file(config_path)
        report = run_ours(ours_case(case, config), tmp_path / "out", config)
    assert report["label"] == "prior=vlm:test-vlm,geometry=annotation,open=dataset,opt=none"
    assert (tmp_path / "out" / "mobility.urdf").is_file() and (tmp_path / "out" / "prior" / "mobility.urdf").is_file()
    assert json.loads((tmp_path / "out" / "prior.json").read_text()) == GOOD
    assert report["diagnostics"]["prior"]["axis_err"] == pytest.approx(0.0, abs=1e-6)
    assert report["diagnostics"]["prior"]["pivot_err"] < 1e-6  # the answer has the true hinge
