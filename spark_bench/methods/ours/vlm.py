"""The ``vlm`` structure prior: any OpenAI-compatible chat-completions endpoint with image input.

Standard library only (:mod:`spark_bench.methods.ours.remote`). The request carries the paper's instructions (section 3.1), the
input image as a base64 data URL and, when the server supports structured outputs, the answer's JSON
schema (:func:`spark_bench.methods.ours.structure.answer_schema`). The answer is validated by
:func:`~spark_bench.methods.ours.structure.parse_structure`; HTTP 429/5xx, network errors and invalid answers
are retried with exponential backoff, then reported in one line naming the endpoint.
"""

from __future__ import annotations

import json
import time

from spark_bench.errors import InputError
from spark_bench.methods.ours.remote import Retryable, image_data_url, post_json, with_retries
from spark_bench.methods.ours.structure import CANONICAL_AXES, PriorStructure, answer_schema, parse_structure

SYSTEM_PROMPT = """You are an expert in articulated objects and URDF. From one RGB image of an object you
infer its coarse URDF: the part hierarchy (links and the joints connecting them) and each joint's
parameters. Answer with JSON only."""

INSTRUCTIONS = """Describe the articulated object in the image as a coarse URDF.

Links: every kinematic part (the static body first, then each part that moves on its own: doors,
drawers, lids, buttons, knobs...). Give each a unique name and a semantic label (body, door, drawer,
lid, button, knob, handle, ...).{parts}

Joints: one per non-root link, connecting it to its parent link. For each joint give:
- type: one of fixed, revolute, prismatic;
- axis: one of the canonical directions of the object frame (y up, the object's front towards +z, x to
  the object's right): front (0,0,1), back (0,0,-1), up (0,1,0), down (0,-1,0), right (1,0,0),
  left (-1,0,0). For a prismatic joint it is the direction the part moves when opening (a drawer
  pulled forward is front). For a revolute joint, first find the rotation axis among x, y, z, then its
  sign: counterclockwise rotation is positive, clockwise is negative; a door that opens towards the
  left rotates clockwise about y, so its axis is down (0,-1,0);
- origin: a point on the joint axis (the hinge line of a revolute joint), in the object frame, with the
  object centered at 0 and scaled to fit [-1, 1] in its largest dimension;
- range: large for doors, drawers, lids and other large motions, small for buttons and small parts.
  The lower limit is always 0.
"""

REFINE_INSTRUCTIONS = """A first estimate of this object's coarse URDF is below. Check each joint's type
and axis against the image and correct them where they are wrong; keep the links, the parents and the
origins. Answer with the full corrected coarse URDF in the same JSON form.

{structure}
"""


def build_request(config, image_png: bytes, known_links: list[str] | None = None,
                  labels: dict[str, str] | None = None, refine_from: PriorStructure | None = None) -> dict:
    """The chat-completions request body.

    :param config: a :class:`spark_bench.methods.ours.config.VLMConfig`
    :param image_png: the input image
    :param known_links: part names the answer must use (when the part meshes exist already)
    :param labels: their labels, shown to the model
    :param refine_from: a coarse URDF to correct (the discrete re-prediction of section 3.3)
    """
    parts = ""
    if known_links:
        listing = ", ".join(f"{n} ({(labels or {}).get(n) or 'part'})" for n in known_links)
        parts = f"\nUse exactly these link names, one per part: {listing}."
    text = INSTRUCTIONS.format(parts=parts)
    if refine_from is not None:
        text = REFINE_INSTRUCTIONS.format(structure=json.dumps(
            {k: v for k, v in refine_from.to_dict().items() if k != "source"}, indent=1)) + "\n" + text
    body = {
        "model": config.model,
        "temperature": config.temperature,
        "max_tokens": config.max_tokens,
        "messages": [
            {"role": "system", "content": SYSTEM_PROMPT},
            {"role": "user", "content": [{"type": "text", "text": text},
                                         {"type": "image_url", "image_url": {"url": image_data_url(image_png)}}]},
        ],
    }
    if config.json_schema:
        body["response_format"] = {"type": "json_schema", "json_schema": {
            "name": "coarse_urdf", "strict": True, "schema": answer_schema(known_links)}}
    else:
        body["response_format"] = {"type": "json_object"}
    return body


def _post(url: str, body: dict, api_key_env: str | None, timeout_s: float) -> dict:
    try:
        return json.loads(post_json(url, body, api_key_env, timeout_s))
    except (json.JSONDecodeError, UnicodeDecodeError):
        raise Retryable("the response is not JSON") from None


def answer_content(response: dict) -> dict:
    """The decoded JSON answer of a chat.completion response (code fences tolerated)."""
    try:
        content = response["choices"][0]["message"]["content"]
    except (KeyError, IndexError, TypeError):
        raise Retryable("the response has no choices[0].message.content") from None
    if not isinstance(content, str):
        raise Retryable("the message content is not text")
    text = content.strip()
    if text.startswith("```"):
        text = text.strip("`").removeprefix("json").strip()
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise Retryable(f"the answer is not JSON ({exc.msg} at char {exc.pos})") from None


def request_structure(config, image_png: bytes, known_links: list[str] | None = None,
                      labels: dict[str, str] | None = None, refine_from: PriorStructure | None = None,
                      upper_table: dict | None = None, sleep=time.sleep) -> tuple[PriorStructure, dict]:
    """Ask the VLM for the coarse URDF; returns the validated structure and the raw answer.

    :raises InputError: after ``1 + max_retries`` failed attempts, or at once on HTTP 4xx (not 429)
    """
    url = config.base_url.rstrip("/") + "/chat/completions"
    body = build_request(config, image_png, known_links, labels, refine_from)

    def attempt() -> tuple[PriorStructure, dict]:
        answer = answer_content(_post(url, body, config.api_key_env, config.timeout_s))
        try:
            structure = parse_structure(answer, url, known_links, upper_table)
        except InputError as exc:
            raise Retryable(f"the answer does not fit the coarse-URDF schema: {exc.problem}") from None
        structure.source = "vlm"
        return structure, answer

    return with_retries(attempt, url, config.max_retries, config.backoff_s, "the VLM request", sleep)


def axis_names() -> list[str]:
    """The canonical direction names the answer may use."""
    return list(CANONICAL_AXES)
