def test_a_suggestion_names_each_choice_once_as_shown() -> None:
    from pipette_cli.errors import suggest

    names = ["pipette/PickUpTestTube-v1", "PickUpTestTube-v1"]
    hint = suggest("PickUpTestTub-v1", names, shown_as={"PickUpTestTube-v1": "pipette/PickUpTestTube-v1"})
    assert hint == "did you mean 'pipette/PickUpTestTube-v1'?"
