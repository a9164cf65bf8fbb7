import pytest

from registry import InvalidName, PolicyRef, parse_policy_ref
from registry.references import check_alias, check_policy_name


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("grasp", PolicyRef("grasp")),
        ("grasp@latest", PolicyRef("grasp")),
        ("grasp@3", PolicyRef("grasp", version=3)),
        ("grasp@v12", PolicyRef("grasp", version=12)),
        ("grasp@champion", PolicyRef("grasp", alias="champion")),
        ("i2a.sparse-v2@candidate", PolicyRef("i2a.sparse-v2", alias="candidate")),
    ],
)
def test_parse_policy_ref(text: str, expected: PolicyRef) -> None:
    assert parse_policy_ref(text) == expected
    assert parse_policy_ref(str(expected)) == expected


@pytest.mark.parametrize("text", ["", "@3", "grasp@0", "grasp@-1", "grasp@", "gr asp", "../x@1", "grasp@a b"])
def test_malformed_references_raise(text: str) -> None:
    with pytest.raises(InvalidName):
        parse_policy_ref(text)


@pytest.mark.parametrize("alias", ["latest", "3", "v3", "1abc", "", "a" * 33, "cham pion"])
def test_bad_aliases_raise(alias: str) -> None:
    with pytest.raises(InvalidName):
        check_alias(alias)


def test_policy_name_rules() -> None:
    assert check_policy_name("a" * 64) == "a" * 64
    for bad in ["a" * 65, ".hidden", "x/y", "x@y"]:
        with pytest.raises(InvalidName):
            check_policy_name(bad)
