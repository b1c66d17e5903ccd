"""``--set KEY=VALUE``: the values both training backends read, and the bad items refused."""

import pytest

from multicrane.cli.common import set_overrides, set_value


@pytest.mark.parametrize(
    "text, value",
    [
        ("True", True),
        ("true", True),
        ("FALSE", False),
        ("false", False),
        ("None", None),
        ("null", None),
        ("1e-3", 1e-3),
        ("256", 256),
        ("-0.5", -0.5),
        ("[64, 64]", [64, 64]),
        ("{'net_arch': [128]}", {"net_arch": [128]}),
        ("set", "set"),
        ("cuda:0", "cuda:0"),
        ("", ""),
    ],
)
def test_a_value_is_a_literal_or_the_string(text, value):
    got = set_value(text)
    assert got == value and type(got) is type(value)


def test_items_become_a_dict_with_spaces_around_the_key_and_value_dropped():
    items = ["learning_rate=1e-3", " anneal_lr = true", "policy_kwargs={'a': 1}", "x=a=b"]
    assert set_overrides(items) == {
        "learning_rate": 1e-3,
        "anneal_lr": True,
        "policy_kwargs": {"a": 1},
        "x": "a=b",
    }


@pytest.mark.parametrize("item", ["learning_rate", "=3", " =3", ""])
def test_an_item_without_a_key_and_value_is_refused_by_name(item):
    with pytest.raises(ValueError, match="expected KEY=VALUE") as info:
        set_overrides([item])
    assert repr(item) in str(info.value)


def test_the_train_command_refuses_a_bad_item_cleanly(capsys):
    from multicrane.cli import main

    assert main(["train", "--scenario", "hall-4c", "--set", "learning_rate"]) == 2
    assert "--set 'learning_rate': expected KEY=VALUE" in capsys.readouterr().err
